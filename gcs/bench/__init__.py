"""The benchmarks (``gcs bench``): tools for us, apart from the operator's product.

``paper``: the paper's tables; ``perf``: how the planner and the live station scale
(``perf_live``: the live station's cases; ``web``: with the map page watched);
``plans``: planner settings compared over many maps; ``faults``: the fault campaign
(``fault_runs``: its stations, each in a child process); ``mavlink``: transfer times and
mock capacity; ``common``: what they share; ``machine_pace``: the machine's pace on the day.
Each runs the product through its API (the mission, the planner, ``run_live``),
never through its command line.
"""
