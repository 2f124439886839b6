"""What robots sense and believe: observation sensors, and localization (wheel odometry, the
laser head's beacon fixes, and the modes that combine them).

Importing any of it registers the built-in sensors and localizations, so they can be chosen
by name.
"""

from mobile_envs.sensing import modes, randomized, sensors  # noqa: F401  (register themselves)
