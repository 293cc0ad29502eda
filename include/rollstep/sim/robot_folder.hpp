#pragma once
// A robot is a folder: robots/<name>/ (or any directory) holding everything robot-specific.
// docs/ROBOTS.md lists its files and keys. Here: finding the folder from a name or a path,
// its files, and the cross-checks that run before anything is simulated (the URDF, which the
// controllers use, against the MJCF, which the simulator uses; the description's contact
// frames against both).
#include <string>
#include <vector>

#include "rollstep/sim/plant.hpp"

namespace rollstep::sim {

/// The files of a robot folder. Required: centroidal.yaml (the robot description: the URDF
/// it names, contact frames, posture, gaits) and <folder name>.xml (the MJCF). Optional (""
/// when absent): estimation.yaml (the state estimator's tuning), sensors.yaml (the sensor
/// noise of the simulated robot), lidar.yaml (the LiDAR on the robot).
struct RobotFolder {
  std::string directory;    ///< as found, without a trailing '/'
  std::string name;         ///< the folder's name
  std::string description;  ///< directory/centroidal.yaml
  std::string mjcf;         ///< directory/<name>.xml
  std::string estimation;   ///< directory/estimation.yaml or ""
  std::string sensors;      ///< directory/sensors.yaml or ""
  std::string lidar;        ///< directory/lidar.yaml or ""

  /// directory/`file` if it is a regular file, else "" (the robot's own controller
  /// defaults: nmpc.yaml, nmpc_perception.yaml, baseline.yaml).
  std::string optionalFile(const std::string& file) const;
};

/// The folder of `name_or_dir`: a path (it contains '/', or is "." or "..") is the folder
/// itself; a plain name is robotsDirectory()/name. Throws InputError naming the folder and the
/// missing item (the folder, centroidal.yaml, the MJCF) and, for an unknown name, the robots
/// there are.
RobotFolder findRobotFolder(const std::string& name_or_dir);

/// The default robot (tachyon3 under robotsDirectory()).
RobotFolder defaultRobotFolder();

/// Plant options that simulate the folder's robot (its MJCF, its description's contact
/// frames and drive wheels).
PlantOptions plantOptionsFor(const RobotFolder& folder);

/// Checks the folder's files against each other, each problem a line naming the file and the
/// item:
///  - the description loads, its URDF loads, and every contact frame is a URDF link and an
///    MJCF body;
///  - the plant loads the MJCF (its structure: actuators, sensors, wheels, keyframe);
///  - every URDF joint that moves is an MJCF joint of the same name, type (revolute or
///    continuous = hinge, prismatic = slide) and axis (1e-6), with the same limits (1e-6) when
///    the URDF has them; every joint of the plant's legs is a URDF joint;
///  - the same mass below every such joint and in all (1e-6 relative, 1e-9 kg absolute);
///  - the description's posture is inside the MJCF's joint ranges and its wheel radius
///    (contact_offset) is the MJCF's wheel radius (1e-4 m).
/// Returns the problems (empty: consistent).
std::vector<std::string> crossCheckRobotFolder(const RobotFolder& folder);

/// crossCheckRobotFolder, throwing InputError with every problem when there is one.
void requireConsistentRobotFolder(const RobotFolder& folder);

}  // namespace rollstep::sim
