"""What a run produced, offline or live: the ``RunResult``, ``report.json`` with the
terminal summary, and the PNG figures."""
