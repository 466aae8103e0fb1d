"""Analysis layer: evaluating formulas and plans.

The exact monitor (``monitor``, ``monitor_demand``) and its smooth numpy reference
(``smooth``, ``smooth_demand``), risk over uncertain poses (``risk``, ``risk_measures``,
``sampling``), the assessment of a plan (``assess``), signal traces (``trace``) and the
multirotor geometry (``geometry``).
"""
