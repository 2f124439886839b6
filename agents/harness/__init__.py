"""Measuring agents: the evaluation harness and the comparison of agents on the same episodes."""
