"""The Gymnasium and Stable-Baselines3 faces of the core: the single env (N = 1), the vector
env (N > 1), what both present (spaces, infos) and the SB3 ``VecEnv`` adapter."""
