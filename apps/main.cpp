// rollstep: command line entry point. See `rollstep --help` and docs/USER_GUIDE.md.
#include <cstdio>
#include <exception>

#include "commands.hpp"

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
      "Exit status: 0 on success, non-zero on bad options or a failed run.");
  rollstep::apps::registerSimCommand(app);
  int exit_status = 0;
  rollstep::apps::registerPlanCommand(app, exit_status);
  rollstep::apps::registerReportCommand(app, exit_status);
  rollstep::apps::registerTrialsCommand(app);
  rollstep::apps::registerViewCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);  // prints help or "error: ..." and returns the exit code
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rollstep: error: %s\n", e.what());
    return 1;
  }
  return exit_status;
}
