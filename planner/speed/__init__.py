"""The planner's speed: the compiled target search (``compiled_search``), its numba
kernels (``search_kernels``, ``bounds``, ``walks``, ``walk_back``), the landmarks'
lower bounds (``landmarks``) and what it keeps of each agent (``memory``,
``settled_target``). Nothing here changes a plan: ``planner.reference_search``
answers the same, plainly.
"""
