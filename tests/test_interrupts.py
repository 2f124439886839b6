"""agents.interrupts: a stop signal is recorded or raised, and found again when compiled code wraps
it; agents.training.checkpoints.StopOnRequest ends training at the step the signal arrived in."""

from __future__ import annotations

import pathlib
import signal
import subprocess
import sys

import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback

from agents.interrupts import Interrupted, StopRequests, interruption_in, signum_of
from agents.training.checkpoints import StopOnRequest
from agents.training.imitation import warm_start
from mobile_envs.envs.sb3 import PathFollowingSB3VecEnv
from mobile_envs.sim.step import clipped_to_unit


def signal_inside_numba(signum: int):
    """A profile hook that raises ``signum`` when numba's dispatcher next calls into Python
    (``_numba_unpickle``, which every call of a kernel returning an array makes): the moment
    at which a scheduler's SIGTERM failed a CI run, made certain."""

    def hook(frame, event, arg):
        if event == "call" and frame.f_code.co_name == "_numba_unpickle":
            sys.setprofile(None)
            signal.raise_signal(signum)

    return hook


@pytest.fixture
def requests():
    stop = StopRequests()
    with stop.installed():
        yield stop
    sys.setprofile(None)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_the_first_stop_signal_is_recorded_and_a_second_raises(signum):
    before = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    with StopRequests().installed() as requests:
        requests.raise_if_requested()  # nothing yet
        signal.raise_signal(signum)
        assert requests.requested and requests.signum == signum
        assert not requests.forced  # recorded, for a poller to honour
        with pytest.raises(Interrupted) as again:
            signal.raise_signal(signal.SIGTERM)
        assert again.value.signum == signal.SIGTERM
        assert requests.forced  # raised at once: nothing saved
        assert requests.signum == signum  # the first one is what the run reports
        with pytest.raises(Interrupted) as polled:
            requests.raise_if_requested()
        assert polled.value.signum == signum_of(polled.value) == signum
    assert {number: signal.getsignal(number) for number in before} == before


def test_a_request_from_another_thread_is_polled_and_a_signal_after_it_still_only_recorded():
    """A grid worker's parent asks it to stop through request(); the system may send SIGTERM
    as well (Slurm, Kubernetes): the worker must still save, not abandon the save."""
    with StopRequests().installed() as requests:
        requests.request(signal.SIGTERM)
        assert requests.requested and requests.signum is None
        with pytest.raises(Interrupted) as polled:
            requests.raise_if_requested()
        assert polled.value.signum == signal.SIGTERM
        signal.raise_signal(signal.SIGINT)  # the first real signal: recorded
        assert requests.signum == signal.SIGINT
        with pytest.raises(Interrupted):
            signal.raise_signal(signal.SIGTERM)  # the second: raised


def test_an_interruption_that_numba_wraps_in_a_system_error_is_found(requests):
    actions = np.zeros((4, 2))
    clipped_to_unit(actions, 4, 2)  # compiled before the hook goes in
    requests.signum = signal.SIGINT  # a first signal came: the next one raises
    sys.setprofile(signal_inside_numba(signal.SIGTERM))
    with pytest.raises(SystemError) as raised:
        clipped_to_unit(actions, 4, 2)
    assert "returned a result with an exception set" in str(raised.value)
    found = interruption_in(raised.value)
    assert isinstance(found, Interrupted) and found.signum == signal.SIGTERM


def test_errors_that_no_signal_caused_are_not_interruptions():
    assert interruption_in(SystemError("a bug")) is None
    assert interruption_in(ValueError("bad")) is None
    plain = KeyboardInterrupt()
    assert interruption_in(plain) is plain and signum_of(plain) == signal.SIGINT
    # A full disk while saving after Ctrl-C is a failure of its own, not the interruption.
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise OSError(28, "No space left on device") from None
    except OSError as during_the_save:
        assert interruption_in(during_the_save) is None


class CountSteps(BaseCallback):
    def __init__(self, signal_at: int | None = None, inside_numba: bool = False):
        super().__init__()
        self.steps = 0
        self.signal_at = signal_at
        self.inside_numba = inside_numba

    def _on_step(self) -> bool:
        self.steps += 1
        if self.steps == self.signal_at:
            if self.inside_numba:  # in the next env.step's kernels
                sys.setprofile(signal_inside_numba(signal.SIGTERM))
            else:
                signal.raise_signal(signal.SIGTERM)
        return True


def small_ppo() -> PPO:
    env = PathFollowingSB3VecEnv("mobile_envs/DiffDrive-Random-v0", 2, seed=0)
    return PPO("MlpPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")


@pytest.mark.parametrize("inside_numba", [False, True], ids=["in-python", "inside-numba"])
def test_a_signal_during_learn_ends_it_at_that_step_and_the_other_callbacks_stop(
    requests, inside_numba
):
    model = small_ppo()
    counter = CountSteps(signal_at=5, inside_numba=inside_numba)
    model.learn(1000, callback=StopOnRequest(requests, [counter]))
    # The signal came during step 5's callbacks, or inside the kernels of step 6's env.step;
    # either way learn ends when step 6 is checked, before the other callbacks run again.
    assert counter.steps == 5
    assert model.num_timesteps == 6 * model.n_envs
    assert requests.signum == signal.SIGTERM
    with pytest.raises(Interrupted):
        requests.raise_if_requested()


def test_a_signal_during_the_warm_start_stops_it_at_its_next_step_before_any_cloning(requests):
    model = small_ppo()
    before = [parameter.detach().clone() for parameter in model.policy.parameters()]
    polls = 0

    def check_stop():
        nonlocal polls
        polls += 1
        if polls == 3:  # the signal comes inside the kernels of the third recorded step
            sys.setprofile(signal_inside_numba(signal.SIGTERM))
        requests.raise_if_requested()

    with pytest.raises(Interrupted) as raised:
        warm_start(
            model, "mobile_envs/DiffDrive-Random-v0", robots=2, steps=50, check_stop=check_stop
        )
    assert raised.value.signum == signal.SIGTERM and polls == 4
    after = list(model.policy.parameters())
    assert all(bool((old == new).all()) for old, new in zip(before, after, strict=True))


ROOT = pathlib.Path(__file__).resolve().parents[1]
#: Runs train.py with a Ctrl-C (or SIGTERM) raised inside the first numba kernel call that
#: reaches Python: the first call of a course path's geometry, which boxes arrays. With
#: Python's own handler there, the process died of a segmentation fault.
SIGNAL_IN_FIRST_KERNEL = """
import signal, sys
sys.path.insert(0, "tests")
import numpy as np
from mobile_envs.sim.step import clipped_to_unit
from test_interrupts import signal_inside_numba
import train
clipped_to_unit(np.zeros((1, 2)), 1, 2)  # loaded before the hook goes in
sys.setprofile(signal_inside_numba(int(sys.argv[1])))
sys.exit(train.main(sys.argv[2:]))
"""


@pytest.mark.parametrize(
    ("command", "signum"),
    [
        (["compare", "--agents", "pure_pursuit", "--episodes", "1"], signal.SIGINT),
        (["compare", "--agents", "pure_pursuit", "--episodes", "1"], signal.SIGTERM),
        (["evaluate", "--model", "models/diffdrive_ppo.zip", "--episodes", "1"], signal.SIGINT),
    ],
    ids=["compare-ctrl-c", "compare-sigterm", "evaluate-ctrl-c"],
)
def test_a_signal_inside_a_kernel_stops_the_cli_cleanly_with_128_plus_the_signal(
    command, signum, tmp_path
):
    where = ["--output", str(tmp_path)] if command[0] == "compare" else []
    env = ["--envs" if command[0] == "compare" else "--env", "mobile_envs/DiffDrive-Lines-v0"]
    process = subprocess.run(
        [sys.executable, "-c", SIGNAL_IN_FIRST_KERNEL, str(signum), *command, *env, *where],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert process.returncode == 128 + signum, process.stdout + process.stderr
    assert "Traceback" not in process.stderr
    assert process.stderr.strip().endswith("interrupted")
