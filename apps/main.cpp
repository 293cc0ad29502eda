// rollstep: command line entry point. See `rollstep --help` and docs/USER_GUIDE.md.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "commands.hpp"
#include "rollstep/common/interrupt.hpp"
#include "rollstep/common/text_file.hpp"

namespace {

/// Every command's standard output is checked once more at the end (a full device, a closed
/// pipe): its outputs may be complete, but what it printed is not, and the exit status
/// says so.
int checkedStdout(int exit_status) {
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(stderr, "rollstep: error: cannot write to standard output: %s\n",
                 std::strerror(errno != 0 ? errno : EIO));
    return exit_status != 0 ? exit_status : 1;
  }
  return exit_status;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "rollstep: full-centroidal NMPC and MuJoCo simulation of the Tachyon 3\n"
      "telescopic-wheeled-legged robot.\n"
      "Run `rollstep <command> --help` for the options of a command."};
  app.set_version_flag("--version", "rollstep " ROLLSTEP_VERSION);
  app.require_subcommand(1, 1);
  app.footer(
      "Examples:\n"
      "  rollstep sim --scene flat --controller stand --duration 10 --out out/stand\n"
      "  rollstep sim --scene flat --controller drive --speed 0.5 --duration 10 --out out/drive\n"
      "  rollstep sim --scene-config config/scenes/step20_custom.yaml --controller drive --out "
      "out/step\n"
      "  rollstep plan --scene flat --gait trot --vx 0.15 --duration 1.5 --out out/plan\n"
      "  rollstep report --out out/report\n"
      "  rollstep trials --scenario step20 --controller nmpc --seeds 0-29 --jobs 2 --out "
      "out/trials\n"
      "  rollstep view out/drive\n"
      "  rollstep check-robot robots/tachyon3\n"
      "Exit status: 0 on success; 74 when an output could not be written (a full disk, no\n"
      "permission): the outputs are absent, not the run's verdict; 128 + N after signal N;\n"
      "another non-zero status on bad options or a failed run.");
  rollstep::apps::registerSimCommand(app);
  int exit_status = 0;
  rollstep::apps::registerPlanCommand(app, exit_status);
  rollstep::apps::registerReportCommand(app, exit_status);
  rollstep::apps::registerTrialsCommand(app, exit_status);
  rollstep::apps::registerViewCommand(app);
  rollstep::apps::registerCheckRobotCommand(app, exit_status);
  // A first word that is neither an option nor a command: CLI11 would only say that a
  // subcommand is required.
  std::string names;
  bool known = false;
  const CLI::App& commands = app;
  for (const CLI::App* sub : commands.get_subcommands([](const CLI::App*) { return true; })) {
    names += (names.empty() ? "" : ", ") + sub->get_name();
    known = known || (argc > 1 && sub->get_name() == argv[1]);
  }
  if (argc > 1 && argv[1][0] != '-' && !known) {
    std::fprintf(stderr,
                 "rollstep: error: '%s' is not a command (the commands: %s; see "
                 "rollstep --help)\n",
                 argv[1], names.c_str());
    return 2;
  }
  rollstep::installInterruptHandlers();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return checkedStdout(app.exit(e));  // prints help or "error: ..." and returns the code
  } catch (const rollstep::Interrupted& e) {
    std::fprintf(stderr, "rollstep: %s\n", e.what());
    return 128 + e.signal();
  } catch (const rollstep::OutputError& e) {
    std::fprintf(stderr, "rollstep: error: %s\n", e.what());
    return rollstep::kOutputErrorExitStatus;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rollstep: error: %s\n", e.what());
    return 1;
  }
  return checkedStdout(exit_status);
}
