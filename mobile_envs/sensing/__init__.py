"""What robots sense and believe: observation sensors, and localization (wheel odometry, the
laser head's beacon fixes, and the modes that combine them).

Importing any of it registers the built-in sensors and localizations, so they can be chosen
by name.
"""

from mobile_envs.sensing import modes, randomized, sensors  # noqa: F401  (register themselves)

# The modes' id facts, stated here until mobile_envs/sensing/modes.py (being reworked on
# another branch) declares them on its classes, where they belong.
modes.OdometryLocalization.env_id = "Odometry"
modes.OdometryLocalization.needs_encoders = True
modes.BeaconLocalization.env_id = "Beacons"
modes.OdometryBeaconLocalization.env_id = "OdometryBeacons"
modes.OdometryBeaconLocalization.needs_encoders = True
