#pragma once
// The controller tests' closed-loop warm-up (compute, command, step) and the pipeline's
// internal state as the input of a bare tick().
#include "rollstep/control/robot_state.hpp"
#include "rollstep/sim/plant.hpp"
#include "rollstep/sim/simple_controllers.hpp"

namespace rollstep::sim::test {

/// n control ticks of `controller` on `plant`, in closed loop.
inline void runTicks(Controller& controller, Plant& plant, int n) {
  PlantCommand command = plant.command();
  for (int k = 0; k < n; ++k) {
    controller.compute(plant.time(), plant.sensors(), command);
    plant.setCommand(command);
    plant.step();
  }
}

/// The pipeline's internal state (its state integrator's q, v) at time t.
template <class Pipeline>
control::RobotState internalState(const Pipeline& pipeline, double t) {
  control::RobotState s = pipeline.makeState();
  control::fromModelState(t, pipeline.integrator().q(), pipeline.integrator().v(), s);
  return s;
}

}  // namespace rollstep::sim::test
