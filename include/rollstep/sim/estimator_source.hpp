#pragma once
// The state estimator (estimation/invariant_ekf.hpp) as the pipeline's StateSource: the
// plant's sensor readings (noisy with PlantOptions::sensor_noise) in, a RobotState out.
// Ground truth is read once, at construction, for the start pose (the robot starts at a
// known place: the map's origin), never after.
//
// Contacts of the robot description: a drive wheel is a DriveWheel, any other contact an
// OmniWheel (Tachyon 3's middle legs carry passive omni wheels), both of the description's
// contact_offset as radius. Contacts are matched to the plant's legs by their contact frame
// (PlantLayout::Leg::contact_frame), as the controller matches its wheels.
// The map: with `ground_heights`, each contact's ground height is the scene's terrain height
// under the contact's last estimated ground point (the scene stands in for the perception
// layer's elevation map, which the robot would use).
#include <memory>
#include <vector>

#include "rollstep/centroidal/robot.hpp"
#include "rollstep/estimation/invariant_ekf.hpp"
#include "rollstep/sim/nmpc_controller.hpp"

namespace rollstep::sim {

class EstimatorSource final : public StateSource {
 public:
  /// `joint_map[j]`: the plant joint index of model joint j. Throws std::invalid_argument
  /// for a contact the plant has no leg for, or bad settings.
  EstimatorSource(const Plant& plant, const centroidal::CentroidalRobot& robot,
                  std::vector<int> joint_map, const estimation::InekfSettings& settings,
                  bool ground_heights = true);
  /// One filter tick on the sensors; the state from the estimate (base pose, world
  /// velocity, gyro less bias, the last accepted encoder sample). Always true once started.
  bool read(double t, const SensorReadings& sensors, control::RobotState& state) override;

  const estimation::InvariantEkf& filter() const { return *filter_; }
  /// Plant leg of each estimator contact.
  const std::vector<int>& contactLegs() const { return contact_leg_; }

 private:
  std::unique_ptr<estimation::InvariantEkf> filter_;
  std::vector<int> joint_map_;
  std::vector<int> contact_leg_;    // estimator contact -> plant leg
  std::vector<int> contact_wheel_;  // estimator contact -> plant drive wheel, or -1
  estimation::EstimatorInput input_;
  SceneGeometry scene_;  // resolved once: the ground heights are read every tick
  bool ground_heights_ = true;
};

/// The estimator's contacts for a centroidal robot description (see above).
std::vector<estimation::ContactSpec> estimatorContacts(const centroidal::CentroidalRobot& robot);

}  // namespace rollstep::sim
