"""The batched simulation: settings, packed per-robot columns, the observation layout, the
compiled step and the core that runs N robots."""
