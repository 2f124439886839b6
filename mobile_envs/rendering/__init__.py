"""Frames: one robot on its path (:mod:`~mobile_envs.rendering.frame`) and a whole batch
(:mod:`~mobile_envs.rendering.batch`)."""
