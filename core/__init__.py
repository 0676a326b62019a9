"""What every layer shares: grid cells and compass directions (``core.cells``), the
geographic frame and compass bearings (``core.geo``), and injected time
(``core.clocks``).

``core`` is the bottom layer: it imports nothing from ``planner``, ``vehicles``,
``sitl_mock`` or ``gcs``, so each of them can use it without depending on another.
"""
