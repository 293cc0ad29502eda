#pragma once
// Subcommands of the rollstep program. Each registerX adds its subcommand to the app
// and arranges for it to run (via a final callback) when selected. To add one (mpc demo,
// step20 experiment, ...): write x_command.cpp with registerXCommand, list it in
// apps/CMakeLists.txt and call it from main.cpp.
#include <CLI/CLI.hpp>

namespace rollstep::apps {

/// `rollstep sim`: run the MuJoCo plant with a simple controller, write a CSV log.
void registerSimCommand(CLI::App& app);

/// `rollstep plan`: solve the full-centroidal OCP once, write the trajectory and a summary.
/// Sets exit_status (0 converged, 3 not converged) when it ran.
void registerPlanCommand(CLI::App& app, int& exit_status);

/// `rollstep report`: run the experiments and write the report. Sets exit_status (0, or 3
/// with --check when a run failed or the acceptance was not met).
void registerReportCommand(CLI::App& app, int& exit_status);

/// `rollstep trials`: randomized trials, their result files and aggregate.
void registerTrialsCommand(CLI::App& app, int& exit_status);

/// `rollstep view DIR`: write the replay page of a `rollstep sim` output folder.
void registerViewCommand(CLI::App& app);
/// `rollstep check-robot DIR`: a robot folder loaded, cross-checked and stood up.
void registerCheckRobotCommand(CLI::App& app, int& exit_status);

}  // namespace rollstep::apps
