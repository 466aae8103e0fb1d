"""What the Python API hands out: ``Plan`` (``plan``; figures in ``figures``), and the
commands it runs beyond ``compile`` — ``simulate``, ``sweep``, ``risk`` (``runs``) — with
the inputs they take (``inputs``)."""
