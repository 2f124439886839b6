"""Classical path-tracking agents and the evaluation harness for mobile_envs."""
