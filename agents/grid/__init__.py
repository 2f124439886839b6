"""Many-seed grids: independent trainings, each measured by the harness, locally or on Ray,
and statistics across seeds."""
