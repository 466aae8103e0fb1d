"""The team family (paper B): the task-assignment seed and the waypoint refinement."""
