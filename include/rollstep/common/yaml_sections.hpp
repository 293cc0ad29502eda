#pragma once
// Configuration files made of sections of numbers, read by one rule:
//
//   seed: 7            # a top-level number
//   imu:               # a section: a mapping of numbers
//     gyro_noise_density: 2.4e-4
//
// Every key must be known (a table of NumberField per section), appear once, and hold a
// plain finite number inside its range; errors name the source, the line and the key:
//   "<source>: line <n>: <section>.<key>: <problem>".
// Used by the sensor model of the simulator and the state estimator's tuning.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace rollstep::yaml {

/// One number of a section: its key, where it goes, and its inclusive range [min, max].
struct NumberField {
  const char* key;
  double* value;
  double min;
  double max;
};

/// A section: its key at the top level of the file ("" for the top-level numbers) and its
/// fields.
struct NumberSection {
  const char* key;
  std::vector<NumberField> fields;
};

/// Reads YAML text into the sections' fields (a key that is absent keeps its value, the
/// documented default). The root must be a mapping (or empty). Throws std::runtime_error as
/// described above for malformed YAML, an unknown or repeated key (top level or inside a
/// section), a section that is not a mapping, a value that is not a plain number, not
/// finite, or outside [min, max].
void readNumberSections(const std::string& yaml_text, const std::string& source,
                        const std::vector<NumberSection>& sections);

}  // namespace rollstep::yaml
