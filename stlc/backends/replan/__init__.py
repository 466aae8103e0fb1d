"""The replanning planners, run by the simulation on each event's problem: the segment NLP,
the operator move's replan and the backup drone's takeover."""
