#pragma once
// Reference scenes of the Tachyon 3 experiments (shared robot/tachyon3.md, "Reference
// scenes"): `flat`, `step20`, `stairs2`, with every dimension a parameter so that
// randomized trials can vary them.
//
// Frames and units: world frame x forward, y left, z up, metres. The robot starts with
// its base centre at x = 0, y = 0 and faces +x; `start_x` is the distance from there to
// the near edge of the first block. Blocks are static boxes resting on the floor
// (z = 0), spanning y in [-width/2, width/2].
//
//   flat    : the floor only.
//   step20  : one block, step1_height high (0.20), step1_length long (1.20).
//   stairs2 : a step1_height rise (0.20) onto a step1_length landing (1.20), then a
//             step2_height rise (0.165) onto a step2_length top landing (1.50), whose
//             far end drops back to the floor.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace rollstep::sim {

enum class SceneKind { kFlat, kStep20, kStairs2 };

/// "flat", "step20" or "stairs2".
std::string_view toString(SceneKind kind);
/// Inverse of toString; throws std::invalid_argument naming the accepted values.
SceneKind sceneKindFromString(std::string_view name);
/// Every scene's name (toString of each SceneKind), in declaration order.
const std::vector<std::string>& sceneNames();
/// Whether `name` is one of sceneNames().
bool isSceneName(std::string_view name);
/// sceneNames() for messages: "flat, step20 or stairs2".
std::string sceneNamesText();

/// Scene parameters. Defaults are the spec's values. YAML keys have the same names as
/// the members (see loadSceneConfig); sceneFields() lists each numeric one with its unit
/// and valid range.
struct SceneConfig {
  SceneKind kind = SceneKind::kFlat;
  double friction = 0.8;        ///< sliding friction coefficient of the terrain
  double start_x = 1.0;         ///< [m] base start (x = 0) to the near edge of block 1
  double width = 3.0;           ///< [m] lateral extent of the blocks
  double step1_height = 0.20;   ///< [m] step20 block height; stairs2 first rise
  double step1_length = 1.20;   ///< [m] step20 block length; stairs2 first landing
  double step2_height = 0.165;  ///< [m] stairs2 second rise (top at step1 + step2)
  double step2_length = 1.50;   ///< [m] stairs2 top landing length
  /// Where the parameters came from, for error messages ("scene config 'FILE'"; set by
  /// parseSceneConfig/loadSceneConfig), or empty.
  std::string source;

  /// Throws std::invalid_argument naming the first parameter that is not finite or
  /// outside its range of sceneFields(), with its value and the range. Ranges that
  /// depend on the robot (start_x must clear the robot's footprint) are checked by the
  /// Plant, which knows the robot.
  void validate() const;
};

/// A numeric scene parameter: its YAML key, member, unit, valid range [min, max]
/// (inclusive) and meaning. The one table behind parsing, validation, toYaml and the
/// user guide (docs/USER_GUIDE.md).
struct SceneField {
  const char* key;
  double SceneConfig::*member;
  const char* unit;  ///< "m" or "" (dimensionless)
  double min;
  double max;
  const char* meaning;
};
inline constexpr std::size_t kNumSceneFields = 7;
const std::array<SceneField, kNumSceneFields>& sceneFields();

/// Reads a YAML mapping with any subset of the keys
///   scene (flat|step20|stairs2), friction, start_x, width, step1_height,
///   step1_length, step2_height, step2_length
/// starting from the defaults above. Errors (std::runtime_error, message
/// "scene config '<file>': line <n>: <key>: <problem>"): the file is missing or not a
/// regular file (a FIFO or device is refused without reading it) or larger than 1 MiB;
/// YAML syntax; more than one YAML document; not a mapping; unknown or repeated keys;
/// a missing value, a list or mapping, or a quoted string where a number is expected;
/// a number that is not finite or outside its range (sceneFields()).
SceneConfig loadSceneConfig(const std::string& yaml_file);
/// Same, from YAML text; `source_name` is used in error messages.
SceneConfig parseSceneConfig(const std::string& yaml_text, const std::string& source_name);
/// Every parameter as YAML text that parseSceneConfig reads back exactly.
std::string toYaml(const SceneConfig& config);

/// An axis-aligned static box of the terrain, world frame.
struct TerrainBox {
  Eigen::Vector3d center;
  Eigen::Vector3d half_size;
};

/// The blocks of the scene (empty for flat), in order of increasing x.
std::vector<TerrainBox> terrainBoxes(const SceneConfig& config);

/// Ground-truth terrain height [m] at world (x, y): the top of the highest block there,
/// or 0 for the floor.
double terrainHeight(const SceneConfig& config, double x, double y);

/// MJCF elements (for a <worldbody>) of the floor, blocks and lights. Terrain geoms are
/// in geom group 0 (the raycast group) and collide with the robot.
std::string terrainMjcf(const SceneConfig& config);

}  // namespace rollstep::sim
