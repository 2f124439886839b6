"""What the sweep tests need: importing this module skips the importing test module, with
the reason, unless the train and sweep extras are installed."""

import pytest

pytest.importorskip("yaml", reason="sweeps read YAML (the train extra)")
pytest.importorskip("optuna", reason="sweeps need the sweep extra")
pytest.importorskip("stable_baselines3", reason="training needs the train extra")
