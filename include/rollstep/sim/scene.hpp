#pragma once
// Scenes as data: a scene file lists the terrain's boxes and ramps and its friction; the
// simulator's world (terrainMjcf), the planner's ground-truth terrain (scene_terrain.hpp)
// and the estimator's ground heights are all built from that one list.
//
// Frames and units: world frame x forward, y left, z up, metres, angles in degrees in the
// file. The robot starts with its base centre at x = 0, y = 0 facing +x; no box or ramp may
// reach into the square around the start that the robot needs (Plant checks it, it knows
// the robot). The floor is the plane z = 0 over [-50, 50] m x [-50, 50] m.
//
// A scene file (config/scenes/*.yaml; docs/USER_GUIDE.md "Scenes"):
//
//   parameters:              # named numbers (optional); trials can draw them
//     height: 0.2
//   friction: 0.8            # terrain friction coefficient (default 0.8)
//   boxes:                   # static boxes
//     - position: [1.5, 0, 0.5 * height]   # centre [m]
//       size: [1.0, 3.0, height]           # full edge lengths [m] along the box's x, y, z
//       yaw_deg: 0                         # rotation about z [deg] (default 0)
//   ramps:                   # inclined boxes: a box pitched so that its top rises
//     - position: [...]      # by slope_deg towards the ramp's +x (after the yaw);
//       size: [...]          # |slope_deg| <= 20
//       yaw_deg: 0
//       slope_deg: 15
//
// Every number may be an arithmetic expression of numbers and parameter names with
// + - * / and parentheses, evaluated left to right as C++ would (0.5 * a + b). A file may
// start from another scene (`base: step20` or a path relative to the file): it inherits
// the base's parameters, friction, boxes and ramps, may change the values of the base's
// parameters and the friction, and appends its own boxes and ramps.
#include <Eigen/Core>
#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace rollstep::yaml {
class Node;
}
namespace rollstep::settings {
class Reader;
}

namespace rollstep::sim {

/// A number of a scene file as written: an expression of numbers and parameters.
struct SceneValue {
  std::string text = "0";
  std::string where;  ///< "scene 'FILE': line N" for messages (empty when set in code)
};

/// A named number of a scene file (its `parameters` mapping).
struct SceneParameter {
  std::string name;
  double value = 0.0;
  std::string where;
};

/// A box or ramp as written.
struct SceneSolidSpec {
  std::array<SceneValue, 3> position;  ///< centre [m]
  std::array<SceneValue, 3> size;      ///< full edge lengths [m]
  SceneValue yaw_deg;
  SceneValue slope_deg;  ///< ramps only
  std::string where;     ///< of the item
};

/// A scene: what a scene file holds, its numbers still expressions of its parameters.
struct SceneConfig {
  std::string name = "flat";  ///< the file's name without .yaml (or "flat" for the default)
  /// Where it came from, for messages ("scene 'FILE'"), or empty.
  std::string source;
  std::vector<SceneParameter> parameters;
  SceneValue friction{"0.8", ""};
  std::vector<SceneSolidSpec> boxes;
  std::vector<SceneSolidSpec> ramps;

  /// Resolves every number and checks it (scene(); see resolveScene). Throws
  /// std::invalid_argument naming the item, its line and the problem.
  void validate() const;
};

/// A resolved box or ramp, world frame.
struct SceneSolid {
  bool ramp = false;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();     ///< [m]
  Eigen::Vector3d half_size = Eigen::Vector3d::Zero();  ///< [m], > 0
  double yaw = 0.0;                                     ///< [rad]
  double slope = 0.0;  ///< [rad] pitch of the top face, rising towards the solid's +x
  std::string label;   ///< "boxes[0] (scene 'FILE': line 7)" for messages

  /// World orientation: yaw about z, then the slope about the solid's own y axis.
  Eigen::Matrix3d rotation() const;
  /// Corners of the top face seen from above, counter-clockwise [m].
  std::array<Eigen::Vector2d, 4> topFootprint() const;
  /// Unit normal of the top face (z > 0) and the top face's centre [m].
  Eigen::Vector3d topNormal() const;
  Eigen::Vector3d topCenter() const;
  /// Whether (x, y) lies on the top face seen from above (edges included), and the top
  /// face's height there.
  bool coversTop(double x, double y) const;
  double topHeightAt(double x, double y) const;
};

/// A scene's numbers resolved.
struct SceneGeometry {
  std::string name;
  double friction = 0.8;
  std::vector<SceneSolid> solids;  ///< the boxes in file order, then the ramps
};

/// Limits of a scene file's numbers (checked by resolveScene).
inline constexpr double kSceneMaxSlopeDeg = 20.0;
inline constexpr double kSceneMinFriction = 0.01, kSceneMaxFriction = 5.0;
inline constexpr double kSceneMaxSize = 100.0;   ///< [m] largest edge of a box
inline constexpr double kSceneMaxExtent = 50.0;  ///< [m] every solid within the floor

/// The numbers of `config`, checked: friction within [0.01, 5]; sizes > 0 and <= 100 m;
/// slopes within +-20 deg; every solid within the floor (|x|, |y| <= 50 m); every number
/// finite. Throws std::invalid_argument "<where>: <key path>: <problem>" (e.g.
/// "scene 'a.yaml': line 9: boxes[1].size[2]: -0.1 m is not > 0").
SceneGeometry resolveScene(const SceneConfig& config);

/// Scene files: the directory the scene names are looked up in (ROLLSTEP_SCENES_DIR in the
/// environment, else the source tree's config/scenes), its scene names (files NAME.yaml,
/// sorted), whether `name` is one, and the names as text ("flat, stairs2 or step20").
std::string scenesDirectory();
std::vector<std::string> sceneNames();
bool isSceneName(std::string_view name);
std::string sceneNamesText();

/// A scene by name (scenesDirectory()/NAME.yaml) or, when `name_or_file` contains a '/' or
/// ends in .yaml, from that file. Throws std::invalid_argument naming the accepted names for
/// an unknown name, std::runtime_error (loadSceneConfig's) for a bad file.
SceneConfig loadScene(const std::string& name_or_file);

/// Reads a scene file (format above). Errors (std::runtime_error, message
/// "scene '<file>': line <n>: <key>: <problem>"): the file is missing, not a regular file
/// or larger than 1 MiB; YAML syntax; more than one document; not a mapping; unknown or
/// repeated keys; a value of the wrong kind (a list where a number is expected, a quoted
/// number); an expression that does not parse or names an unknown parameter; a base that
/// cannot be loaded (or that includes itself); any problem resolveScene finds.
SceneConfig loadSceneConfig(const std::string& yaml_file);
/// Same, from YAML text; `source_name` is used in error messages and `base` paths are
/// relative to its directory.
SceneConfig parseSceneConfig(const std::string& yaml_text, const std::string& source_name);
/// A complete scene file (no base) that parseSceneConfig reads back to the same numbers.
std::string toYaml(const SceneConfig& config);
/// A scene given inside another YAML file (a run spec's `inline_scene:`): `node`, a mapping
/// of a scene file's keys (base: excepted), read with `reader`, key paths under `prefix`
/// ("inline_scene."), then checked as a scene file is; errors as the reader's, naming the
/// line and the key path. The scene's name is `name`.
SceneConfig readSceneConfig(const yaml::Node& node, settings::Reader& reader,
                            const std::string& prefix, const std::string& name);
/// toYaml's keys without its comment line, each line after `indent` (readSceneConfig reads
/// them back to the same numbers).
std::string sceneYaml(const SceneConfig& config, const std::string& indent);
/// The keys of a scene file, each with its default (a box's and a ramp's as comments).
std::string documentedScene();

/// A number of the scene by key path: a parameter's name, "friction", or an item's
/// number ("boxes[0].size[2]", "ramps[1].slope_deg", "boxes[2].yaw_deg"). sceneNumber
/// resolves it; setSceneNumber sets it to `value` (an item's number becomes that
/// constant; a parameter changes and what is computed from it follows). Both throw
/// std::invalid_argument naming the path and the scene's keys when there is no such
/// number.
double sceneNumber(const SceneConfig& config, const std::string& path);
/// Whether the scene has a number at `path`.
bool hasSceneNumber(const SceneConfig& config, const std::string& path);
void setSceneNumber(SceneConfig& config, const std::string& path, double value);

/// Ground-truth terrain height [m] at world (x, y): the top face of the highest solid
/// whose top covers (x, y), or 0 for the floor. No allocation.
double terrainHeight(const SceneGeometry& geometry, double x, double y);
double terrainHeight(const SceneConfig& config, double x, double y);

/// Height of the first solid's top face at its centre (0 for no solids) [m]: the rise of
/// a step scene's first step.
double firstRise(const SceneGeometry& geometry);

/// MJCF elements (for a <worldbody>) of the floor, boxes, ramps and lights. Terrain geoms
/// are in geom group 0 (the raycast group) and collide with the robot.
std::string terrainMjcf(const SceneConfig& config);

/// The first solid that reaches into the square |x|, |y| < half_extent around the robot's
/// start (seen from above), or nullptr.
const SceneSolid* solidAtStart(const SceneGeometry& geometry, double half_extent);

}  // namespace rollstep::sim
