"""The quick suite: ``python -m pytest -m "not slow"`` leaves out the tests marked ``slow``
here, those that start Python processes, train policies, recompile the kernels, run sweeps
and grids, or sweep the whole catalogue of ids (copies, fuzzing, threads). What stays is the
core: the physics, paths, sensors, envs, agents and harness. CI runs every test.

The marks live here, in one place, rather than on the tests: :data:`SLOW_MODULES` marks every
test of a module, :data:`SLOW_TESTS` single test functions (all their parameters).
``tests/test_quick_suite.py`` checks that every name here still names a test.
"""

from __future__ import annotations

from pathlib import Path

import pytest

#: Modules all of whose tests are slow: command lines in fresh processes, training runs,
#: sweeps and grids, copies and fuzzing of every id.
SLOW_MODULES = frozenset(
    {
        "test_cli_errors.py",
        "test_copies.py",
        "test_fuzz.py",
        "test_fuzz_paths.py",
        "test_fuzz_plant.py",
        "test_grid.py",
        "test_ray.py",
        "test_sweep.py",
        "test_sweep_storage.py",
        "test_train.py",
        "test_warm_start_resume.py",
    }
)
#: Slow test functions of the other modules, by module.
SLOW_TESTS: dict[str, frozenset[str]] = {
    "test_clients.py": frozenset(
        {
            "test_cleanrl_make_env_finds_the_ids_through_the_module_prefix",
            "test_the_bare_id_needs_the_import_and_says_so",
            "test_sb3_vec_wrappers_over_the_adapter",
            "test_rl_zoo3_trains_on_an_id_with_gym_packages",
            "test_rl_zoo3_enjoy_and_record_video_load_the_trained_model",
            "test_rl_zoo3_trains_a_random_id_with_the_shipped_hyperparams_and_its_warm_start",
            "test_torchrl_recipe_checks_the_specs_reads_the_info_and_collects",
            "test_skrl_recipe_trains_ppo_on_the_vector_env",
            "test_rllib_recipe_trains_ppo_with_the_module_id_form",
        }
    ),
    "test_array_copies.py": frozenset(
        {"test_a_training_envs_first_steps_compile_no_error_formatting_and_no_literal_twins"}
    ),
    "test_catalogue.py": frozenset(
        {"test_user_code_adds_a_path_set_with_ids_and_beacons_without_editing_the_package"}
    ),
    "test_datasets.py": frozenset({"test_a_ppo_policy_records_through_the_same_command"}),
    "test_gallery.py": frozenset(
        {"test_each_gif_is_320_px_in_the_palette_and_opens_on_the_envs_own_first_frame"}
    ),
    "test_imitation.py": frozenset(
        {"test_a_stopped_warm_start_goes_on_from_its_checkpoint_to_the_same_weights"}
    ),
    "test_interrupts.py": frozenset(
        {"test_a_signal_inside_a_kernel_stops_the_cli_cleanly_with_128_plus_the_signal"}
    ),
    "test_kernel_cache.py": frozenset(
        {
            "test_read_only_install_uses_numbas_user_cache_and_still_follows_edits",
            "test_env_follows_an_edit_to_the_physics_it_inlines",
            "test_concurrent_imports_agree_and_leave_no_temporary_files",
        }
    ),
    "test_parallel.py": frozenset({"test_parallel_vector_env_equals_the_serial_one_bit_for_bit"}),
    "test_plant.py": frozenset(
        {
            "test_the_vector_env_equals_n_single_envs_with_every_imperfection",
            "test_slip_spreads_the_pose_as_eq_17_says_monte_carlo",
        }
    ),
    "test_robustness.py": frozenset({"test_a_tiny_study_writes_its_table_plot_and_numbers"}),
}


def is_slow(module: str, function: str) -> bool:
    """Whether the test ``function`` of ``module`` (a file name) is marked slow."""
    return module in SLOW_MODULES or function in SLOW_TESTS.get(module, frozenset())


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        function = getattr(item, "originalname", item.name)
        if is_slow(Path(str(item.fspath)).name, function):
            item.add_marker(pytest.mark.slow)
