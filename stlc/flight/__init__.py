"""Flight: the plan on a vehicle and a vehicle's log against the plan.

* ``frames`` — the one statement of stlc's frames: ENU world, ZYX Euler attitude of a
  forward-left-up body, the NED/FRD conversion of PX4, quaternions, the bag's epoch;
* ``export`` — flight-stack outputs of a plan (PX4 offboard setpoints, MRS trajectory,
  a ROS 2 bag in MCAP);
* ``logs`` — flight logs in (PX4 ULog, ROS 2 bags) as monitorable traces;
* ``wind``, ``control``, ``rigid``, ``engine`` — the closed loop: Dryden turbulence, the
  geometric SE(3) controller and a PD tracker, the rigid-body and point-mass simulators
  vectorised over runs, and the engine that flies a plan and judges the flown trajectory.
"""
