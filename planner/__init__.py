from planner.native import use_sources_if_stale

use_sources_if_stale()
