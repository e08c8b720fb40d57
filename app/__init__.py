"""The isl dashboard: a Panel app over :mod:`isl_core` (state → views → app)."""
