"""The planner: multi-agent coverage with the staying alive policy.

Importing it does no I/O and compiles nothing: a program that runs the compiled
planner calls ``planner.native.use_sources_if_stale()`` before it imports the
compiled modules, and ``warm_up()`` (``planner.speed.compiled_search``) before it times
anything.
"""
