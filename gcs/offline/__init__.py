"""The offline run of ``gcs plan``: the planner against the simulated truth
(``sitl_mock.LockstepWorld``), iteration by iteration or in ticks of mission time."""
