"""Which checks run in the quick suite (the README's test command) and which under ``slow``.

The quick suite is meant to cost at most 300 CPU-seconds from a fresh clone on two cores, set-up and the
compilation of its kernels included. A check costing more than about a CPU-second is made cheaper first; the ones
below could not be, without losing what they check, and run under ``slow`` (``bash scripts/test.sh -m slow``;
``.ci/run`` runs both tiers). Each entry is a test id, or a test function's id standing for all its cases, with
why it is long. A test whose function is marked ``@pytest.mark.slow`` in its file (a long form beside its small
one) is not listed again. ``tests/conftest.py`` applies the marks and refuses an entry that names no test.

The quick suite also never compiles the model-predictive controller's solver (about 40-70 CPU-s on a fresh
install, a fifth of the budget): a quick test that loads it fails, naming this file (``tests/conftest.py``).
"""

#: The model-predictive controller's solver: compiled once per install, about 40-70 CPU-seconds.
MPC = "runs mpc's solver (its compilation is a fifth of the quick suite's budget)"
#: A trajectory optimisation by IPOPT: seconds each.
PLAN = "solves a kip by trajectory optimisation (IPOPT, seconds)"
#: A study or a reproduction: tens to hundreds of rollouts.
STUDY = "a whole study (tens of rollouts, its figures and files)"
#: A new interpreter per case (Python's libraries and numba's kernels loaded again: 2-5 CPU-s each).
PROCESS = "starts processes (an interpreter costs 2-5 CPU-s to start)"
#: Long runs compared sample by sample, or fine grids.
LONG = "long runs or fine grids compared point by point"
#: The engine on ``mujoco.batch``: compiled for these checks alone.
BATCH = "runs the engine on mujoco.batch (compiled for these checks alone: about 50 CPU-s)"
#: Compiling every kernel again, in a fresh cache.
COMPILE = "compiles every kernel again (about 200 CPU-s on a fresh install)"

SLOW = {
    # the model-predictive controller (its refusals, options and memory layout stay quick)
    "tests/test_mpc.py::test_it_balances_from_near_the_top": MPC,
    "tests/test_mpc.py::test_it_builds_for_the_family": MPC,
    "tests/test_mpc.py::test_motors_without_a_range_plan_afresh_over_a_shorter_horizon_and_climb_from_hanging": MPC,
    "tests/test_mpc.py::test_it_swings_their_acrobot_up": MPC,
    "tests/test_mpc.py::test_the_compiled_law_is_the_python_law": MPC,
    "tests/test_mpc.py::test_it_reads_only_the_measured_state_and_time": MPC,
    "tests/test_mpc.py::test_it_plans_within_the_runs_torque_limit": MPC,
    "tests/test_mpc.py::test_the_estimator_finds_the_loops_latency_and_holds_the_top": MPC,
    "tests/test_mpc.py::test_the_estimator_filters_their_velocity_noise": MPC,
    "tests/test_mpc.py::test_it_balances_a_chain_with_a_passive_middle_joint": MPC,
    "tests/test_mpc.py::test_one_set_of_defaults_swings_the_family_up": MPC,
    "tests/test_mpc.py::test_its_torque_stays_finite_on_a_chain_spun_past_its_plans": MPC,
    "tests/test_mpc.py::test_the_braking_guess_takes_energy_out_of_a_spin": MPC,
    "tests/test_mpc.py::test_a_motor_without_a_range_plans_within_box_times_its_gravity_torque": MPC,
    "tests/test_mpc.py::test_a_loop_slower_than_half_a_knot_gets_the_knots_torque": MPC,
    "tests/test_mpc.py::test_a_restart_spread_over_calls_makes_the_plan_of_one_call": MPC,
    "tests/test_mpc.py::test_a_chain_spun_past_spin_cap_is_braked_not_planned_for": MPC,
    "tests/test_realaigym_board_rows.py::test_the_mpc_row_of_each_board_is_what_its_performance_run_gives": MPC,
    "tests/test_registered_controllers.py::test_builds_binds_and_runs_on_both_engines[mpc-": MPC,
    # trajectory optimisation
    "tests/test_registered_controllers.py::test_builds_binds_and_runs_on_both_engines[trajopt-": PLAN,
    "tests/test_trajopt.py::test_a_believed_model_plans_from_the_plant_s_kip": PLAN,
    "tests/test_trajopt.py::test_compare_quick_json_has_every_key_of_a_controller": PLAN,
    "tests/test_trajopt.py::test_min_time_is_faster_and_min_effort_is_cheaper": PLAN,
    "tests/test_trajopt.py::test_simulate_json_reports_the_plan": PLAN,
    "tests/test_trajopt.py::test_tvlqr_tracks_a_solved_kip_in_mujoco_from_perturbed_starts": PLAN,
    "tests/test_family.py::test_a_planned_kip_tracked_by_tvlqr_balances_the_acrobot": PLAN,
    "tests/test_numbers.py::test_a_cached_plan_that_is_not_the_one_asked_for_is_solved_again": PLAN,
    "tests/test_numbers.py::test_a_min_time_plan_that_cannot_fit_its_time_range_is_refused": PLAN,
    "tests/test_claims.py::test_a_stated_number_is_what_the_code_gives[realaigym_tvlqr_row]": PLAN,
    # studies and the reproduction
    "tests/test_reproduce.py": STUDY,
    "tests/test_atlas.py": STUDY,
    "tests/test_distributed.py": STUDY,
    "tests/test_family.py::test_the_atlas_maps_the_family_beyond_theorem_1": STUDY,
    "tests/test_family_gains.py::test_the_outcome_reads_the_engine_s_entry_into_region_68_not_the_samples": STUDY,
    "tests/test_family_gains.py::test_the_search_scores_rules_by_the_robots_they_balance": STUDY,
    "tests/test_engine.py::test_basin_cli": STUDY,
    "tests/test_engine.py::test_robustness_cli": STUDY,
    "tests/test_engine.py::test_bench_reports_ratios_without_timing_assertions": STUDY,
    "tests/test_edges_folders.py::test_realaigym_protocols_do_not_share_a_folder": STUDY,
    "tests/test_edges_studies.py::test_the_command_says_how_many_were_not_run": STUDY,
    "tests/test_faults_numbers.py::test_a_studys_counts_add_up": STUDY,
    "tests/test_faults_numbers.py::test_json_output_of_every_command_is_one_strict_object[compare": STUDY,
    "tests/test_faults_numbers.py::test_no_reported_torque_exceeds_the_torque_limit_given[compare": STUDY,
    "tests/test_faults_numbers.py::test_no_reported_torque_exceeds_the_torque_limit_given[simulate --controller vc ":
        STUDY,
    "tests/test_faults_numbers.py::test_the_same_command_twice_gives_the_same_numbers[atlas simulate]": STUDY,
    "tests/test_numbers.py::test_chunk_is_honoured_by_compare": STUDY,
    "tests/test_numbers.py::test_chunks_of_an_older_version_do_not_pile_up": STUDY,
    "tests/test_numbers.py::test_every_study_applies_the_torque_limit_and_reports_the_peak": STUDY,
    "tests/test_numbers.py::test_a_changed_controller_file_is_not_resumed_from_old_chunks": STUDY,
    "tests/test_peers.py::test_peers_quick_writes_its_files_and_meets_the_targets": STUDY,
    "tests/test_realaigym_protocols.py::test_command_line_gives_the_same_bytes_twice": STUDY,
    "tests/test_realaigym_protocols.py::test_robustness_on_fewer_levels": STUDY,
    "tests/test_claims.py::test_a_stated_number_is_what_the_code_gives[roa_gymnast]": STUDY,
    "tests/test_claims.py::test_a_stated_number_is_what_the_code_gives[family_switch_times]": STUDY,
    "tests/test_claims.py::test_a_stated_number_is_what_the_code_gives[exact_first_entry]": STUDY,
    "tests/test_claims.py::test_a_stated_number_is_what_the_code_gives[gym_analytic_agreement]": STUDY,
    "tests/test_trust.py::test_same_command_gives_byte_identical_files": STUDY,
    # processes, pipes, signals, rendering
    "tests/test_docs.py::test_a_small_site_builds_without_warnings_by_the_site_s_configuration": PROCESS,
    "tests/test_readme.py::test_the_python_of_a_page_runs_and_prints_what_it_says": PROCESS,
    "tests/test_examples.py::test_offscreen_video": PROCESS,
    "tests/test_video.py::test_render_short_clip": PROCESS,
    "tests/test_video.py::test_replay_saved_trajectory_as_gif": PROCESS,
    "tests/test_faults_input.py::test_a_closed_pipe_ends_quietly": PROCESS,
    "tests/test_faults_input.py::test_a_closed_standard_output_is_written_to_nowhere": PROCESS,
    "tests/test_faults_input.py::test_a_fifo_is_refused_not_waited_on": PROCESS,
    "tests/test_faults_input.py::test_render_interrupted_while_encoding_leaves_no_file": PROCESS,
    "tests/test_faults_models.py::test_the_viewer_that_cannot_open_is_one_line": PROCESS,
    "tests/test_faults_runs.py::test_a_full_standard_output_is_one_line": PROCESS,
    "tests/test_faults_runs.py::test_commands_that_ran_batches_stop_on_an_interrupt_instead_of_reporting_it": PROCESS,
    "tests/test_faults_runs.py::test_mujoco_warnings_leave_no_log_file_and_no_console_lines": PROCESS,
    "tests/test_faults_user_code.py::test_environment_variables_are_read_as_the_libraries_read_them": PROCESS,
    "tests/test_cli_theory.py::test_malformed_model_from_a_subprocess_has_no_traceback": PROCESS,
    "tests/test_numba_settings.py::test_uncompiled_kernels_are_refused_in_one_line": PROCESS,
    "tests/test_engine.py::test_compile_leaves_no_kernel_to_compile_later": COMPILE,
    # long runs and fine grids
    "tests/test_rollout.py::test_the_exact_closed_loop_of_a_compiled_law_is_that_of_its_torque": LONG,
    "tests/test_rollout.py::test_hybrid_controller_balances_table1_analytic": LONG,
    "tests/test_engine.py::test_batch_equals_single_rollouts_bit_for_bit[True]": LONG,
    "tests/test_engine.py::test_compiled_rollout_equals_python_controller_rollout": LONG,
    "tests/test_engine.py::test_python_controllers_run_in_the_batch_engine": LONG,
    "tests/test_mujoco_batch.py": BATCH,
    "tests/test_actuation.py::test_fantonis_swing_up_makes_their_lyapunov_function_decrease_as_designed": LONG,
    "tests/test_balance_sampling.py::test_theory_states_the_step_from_which_the_balance_holds": LONG,
    "tests/test_bounds.py::test_a_bracket_is_kept_with_its_budget_and_reused_for_no_larger_one": LONG,
    "tests/test_bounds.py::test_a_spent_budget_gives_a_certified_bracket_and_the_gains_above_it": LONG,
    "tests/test_bounds.py::test_the_branch_and_bound_gives_the_grids_kd_min_on_random_chains[5]": LONG,
    "tests/test_merged.py::test_an_eight_link_chain_is_decided_within_the_budget": LONG,
    "tests/test_theory.py::test_maxima_are_accurate_to_1e4_against_a_fine_brute_force_grid": LONG,
    "tests/test_long_chains.py::test_the_longest_chain_runs_without_gains_and_is_refused_one_line_where_it_needs_them":
        LONG,
    "tests/test_family.py::test_the_gymnasium_environments_take_the_family": LONG,
    "tests/test_family.py::test_the_lqr_balances_any_chain_at_either_goal": LONG,
    "tests/test_gym.py::test_is_success_is_the_package_success_over_every_physics_step": LONG,
    "tests/test_gym.py::test_render_rgb_array": LONG,
    "tests/test_gym.py::test_the_analytic_engine_refuses_a_policy_held_over_its_period": LONG,
    "tests/test_gym.py::test_the_lqr_balances_every_start_of_the_balance_task": LONG,
}


def matches(entry: str, nodeid: str) -> bool:
    """Whether the entry names the test: a module (``.py``), the start of a case's id (with ``[``), or a function."""
    if "[" in entry:
        return nodeid.startswith(entry)
    if entry.endswith(".py"):
        return nodeid.startswith(entry + "::")
    return nodeid == entry or nodeid.startswith(entry + "[")


def reason(nodeid: str):
    """Why the test ``nodeid`` runs under ``slow`` (None: not listed here)."""
    return next((why for entry, why in SLOW.items() if matches(entry, nodeid)), None)
