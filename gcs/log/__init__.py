"""The mission's record: the log interface every run writes to (``mission_log``), the
MCAP file with raw MAVLink and Foxglove schemas (``mcap_log``), reading it back
(``reader``), and the same topics served live to Foxglove (``foxglove_live``)."""
