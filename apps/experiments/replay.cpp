#include "replay.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "log_table.hpp"
#include "rollstep/common/gzip_text.hpp"
#include "rollstep/common/text_file.hpp"

namespace rollstep::experiments {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json vec(const mjtNum* v, int n) {
  json a = json::array();
  for (int i = 0; i < n; ++i) a.push_back(v[i]);
  return a;
}

const char* geomTypeName(int type) {
  switch (type) {
    case mjGEOM_PLANE:
      return "plane";
    case mjGEOM_SPHERE:
      return "sphere";
    case mjGEOM_CAPSULE:
      return "capsule";
    case mjGEOM_ELLIPSOID:
      return "ellipsoid";
    case mjGEOM_CYLINDER:
      return "cylinder";
    case mjGEOM_BOX:
      return "box";
    case mjGEOM_MESH:
      return "mesh";
    default:
      return nullptr;  // height fields and the rest: not drawn
  }
}

std::string readAll(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(std::string(what) + " '" + path + "': cannot be read");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Columns of `table`, every `stride`-th row (and the last), rounded to 1 / `scale` (a power
/// of ten: the division gives the shortest decimal): what the page plots and poses from.
json columnsOf(const LogTable& table, std::size_t stride, double scale) {
  std::vector<std::size_t> rows;
  for (std::size_t r = 0; r < table.rows(); r += stride) rows.push_back(r);
  if (!rows.empty() && rows.back() + 1 != table.rows()) rows.push_back(table.rows() - 1);
  json names = json::array(), columns = json::array();
  for (const std::string& name : table.names()) {
    const std::vector<double>& c = table.column(name);
    json values = json::array();
    bool any = false;
    for (std::size_t r : rows) {
      if (std::isfinite(c[r])) {
        values.push_back(std::round(c[r] * scale) / scale);
        any = true;
      } else {
        values.push_back(nullptr);
      }
    }
    if (!any) continue;  // a word column (qp_status): not plotted
    names.push_back(name);
    columns.push_back(std::move(values));
  }
  return json{{"names", names}, {"columns", columns}};
}

/// plan.csv.gz for the page, compact (docs/REPLAY.md): every column as integers (times in
/// 0.1 ms, positions in mm, the rest as they are), each value given as its difference from
/// the same node of the previous solution (the previous row for a node the previous
/// solution lacks; the first solution from zero): consecutive plans differ by millimetres,
/// so most numbers are one or two digits. `rows_per_solution` lets the page undo it.
json compactPlan(const LogTable& plan, const std::string& path) {
  const auto bad = [&](const std::string& why) {
    return std::runtime_error("plan '" + path + "': " + why + " (docs/REPLAY.md: plan.csv.gz)");
  };
  // The columns the page draws from: every contact's three, the rest by name.
  for (const char* c : {"solution_time[s]", "time[s]", "sequence[-]", "mode[-]", "base_x[m]",
                        "base_y[m]", "base_z[m]"}) {
    if (!plan.has(c)) throw bad(std::string("no column ") + c);
  }
  for (const std::string& name : plan.names()) {
    const std::string head = "foot_", tail = "_x[m]";
    if (name.rfind(head, 0) != 0 || name.size() < head.size() + tail.size() ||
        name.compare(name.size() - tail.size(), tail.size(), tail) != 0) {
      continue;
    }
    const std::string stem = name.substr(0, name.size() - tail.size());
    for (const char* axis : {"_y[m]", "_z[m]"}) {
      if (!plan.has(stem + axis)) throw bad("column " + name + " without " + stem + axis);
    }
  }
  const auto& t0 = plan.column("solution_time[s]");
  const auto& seq = plan.column("sequence[-]");
  // The page draws at time t the last solution solved at or before t: in order of time.
  for (std::size_t r = 1; r < plan.rows(); ++r) {
    if (t0[r] < t0[r - 1]) {
      throw bad("solution_time[s] goes back in time in data row " + std::to_string(r + 1) + " (" +
                plan.text("solution_time[s]")[r] + " after " +
                plan.text("solution_time[s]")[r - 1] + ")");
    }
  }
  std::vector<std::size_t> starts;  // first row of each solution
  for (std::size_t r = 0; r < plan.rows(); ++r) {
    if (r == 0 || t0[r] != t0[r - 1] || seq[r] != seq[r - 1]) starts.push_back(r);
  }
  starts.push_back(plan.rows());
  // Reference row of each row (-1: none).
  std::vector<long> reference(plan.rows(), -1);
  json rows_per_solution = json::array();
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    const std::size_t n = starts[s + 1] - starts[s];
    rows_per_solution.push_back(n);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t r = starts[s] + k;
      if (s > 0 && k < starts[s] - starts[s - 1]) {
        reference[r] = static_cast<long>(starts[s - 1] + k);
      } else if (k > 0) {
        reference[r] = static_cast<long>(r - 1);
      }
    }
  }
  json names = json::array(), scales = json::array(), columns = json::array();
  for (const std::string& name : plan.names()) {
    const std::vector<double>& c = plan.column(name);
    const double scale = name.find("[s]") != std::string::npos   ? 1e4
                         : name.find("[m]") != std::string::npos ? 1e3
                                                                 : 1.0;
    std::vector<long long> q(c.size());
    for (std::size_t r = 0; r < c.size(); ++r) {
      if (!std::isfinite(c[r])) {
        throw bad(name + " is not a number in data row " + std::to_string(r + 1) + ": '" +
                  plan.text(name)[r] + "'");
      }
      q[r] = std::llround(c[r] * scale);
    }
    json values = json::array();
    for (std::size_t r = 0; r < c.size(); ++r) {
      values.push_back(reference[r] < 0 ? q[r] : q[r] - q[static_cast<std::size_t>(reference[r])]);
    }
    names.push_back(name);
    scales.push_back(scale);
    columns.push_back(std::move(values));
  }
  return json{{"names", names},
              {"scales", scales},
              {"rows_per_solution", rows_per_solution},
              {"columns", columns}};
}

/// A float32 n x n map of `rollstep sim --log-map` (NumPy .npy 1.0, little-endian, C
/// order; docs/PERCEPTION.md). Throws std::runtime_error naming the file.
std::vector<float> readHeights(const std::string& path, int n) {
  const std::string bytes = readAll(path, "elevation map");
  const auto bad = [&](const std::string& why) {
    return std::runtime_error("elevation map '" + path + "': " + why);
  };
  if (bytes.size() < 10 || bytes.compare(0, 6, "\x93NUMPY") != 0 || bytes[6] != 1) {
    throw bad("not a NumPy .npy 1.0 file");
  }
  const std::size_t header = static_cast<unsigned char>(bytes[8]) |
                             static_cast<std::size_t>(static_cast<unsigned char>(bytes[9])) << 8;
  const std::string dict = bytes.substr(10, header);
  const std::string shape = "'shape': (" + std::to_string(n) + ", " + std::to_string(n) + ")";
  if (dict.find("'descr': '<f4'") == std::string::npos ||
      dict.find("'fortran_order': False") == std::string::npos ||
      dict.find(shape) == std::string::npos) {
    throw bad("expected little-endian float32 in C order, " + shape);
  }
  const std::size_t count = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  if (bytes.size() != 10 + header + 4 * count) throw bad("size does not match its shape");
  std::vector<float> out(count);
  std::memcpy(out.data(), bytes.data() + 10 + header, 4 * count);
  return out;
}

/// The elevation maps and foothold regions of a `--log-map` folder (maps.csv, regions.csv,
/// heights_NNNN.npy), at most 40 snapshots evenly chosen, maps halved to at most 100 x 100
/// cells (heights rounded to mm): a few MB for a 30 s run. null without a map log.
json mapSnapshots(const std::string& dir) {
  if (!fs::exists(dir + "/maps.csv")) return nullptr;
  const LogTable maps = LogTable::read(dir + "/maps.csv", "map log");
  const LogTable regions = LogTable::read(dir + "/regions.csv", "map regions");
  const std::vector<std::string>& files = maps.text("heights_file");
  const std::size_t n = maps.rows();
  const std::size_t every = std::max<std::size_t>(1, (n + 39) / 40);
  json out = json::array();
  for (std::size_t r = 0; r < n; r += every) {
    const int size = static_cast<int>(maps.column("size[-]")[r]);
    const int snapshot = static_cast<int>(maps.column("snapshot[-]")[r]);
    if (size <= 0 || size > 4096) throw std::runtime_error("map log '" + dir + "': bad size");
    const std::vector<float> h = readHeights(dir + "/" + files[r], size);
    const int step = size > 100 ? 2 : 1;
    json cells = json::array();
    for (int i = 0; i < size; i += step) {
      for (int j = 0; j < size; j += step) {
        const float v = h[static_cast<std::size_t>(i) * static_cast<std::size_t>(size) +
                          static_cast<std::size_t>(j)];
        if (std::isfinite(v)) {
          cells.push_back(std::round(static_cast<double>(v) * 1000.0) / 1000.0);
        } else {
          cells.push_back(nullptr);
        }
      }
    }
    json polygons = json::array();
    const auto& rs = regions.column("snapshot[-]");
    for (std::size_t k = 0; k < regions.rows(); ++k) {
      if (static_cast<int>(rs[k]) != snapshot) continue;
      if (polygons.empty() || regions.column("vertex[-]")[k] == 0)
        polygons.push_back(json::array());
      polygons.back().push_back(
          {regions.column("x[m]")[k], regions.column("y[m]")[k], regions.column("z[m]")[k]});
    }
    out.push_back({{"time", maps.column("time[s]")[r]},
                   {"origin", {maps.column("origin_x[m]")[r], maps.column("origin_y[m]")[r]}},
                   {"resolution", maps.column("resolution[m]")[r] * step},
                   {"size", (size + step - 1) / step},
                   {"heights", cells},
                   {"regions", polygons}});
  }
  return out;
}

/// The terrains of a perception run (terrains.csv: every vertex of every region of each
/// version): [{version, regions: [[[x, y, z], ...], ...]}, ...] in the file's order, vertices
/// to the millimetre. null without the file.
json terrainVersions(const std::string& path) {
  if (!fs::exists(path)) return nullptr;
  const LogTable t = LogTable::read(path, "terrains");
  for (const char* c : {"version[-]", "region[-]", "vertex[-]", "x[m]", "y[m]", "z[m]"}) {
    if (!t.has(c)) throw std::runtime_error("terrains '" + path + "': no column " + c);
  }
  const auto& version = t.column("version[-]");
  const auto& region = t.column("region[-]");
  const auto mm = [](double v) { return std::round(v * 1000.0) / 1000.0; };
  json out = json::array();
  for (std::size_t k = 0; k < t.rows(); ++k) {
    if (out.empty() || out.back()["version"].get<double>() != version[k]) {
      out.push_back({{"version", version[k]}, {"regions", json::array()}});
    }
    json& regions = out.back()["regions"];
    if (regions.empty() || k == 0 || region[k] != region[k - 1] || t.column("vertex[-]")[k] == 0) {
      regions.push_back(json::array());
    }
    regions.back().push_back(
        {mm(t.column("x[m]")[k]), mm(t.column("y[m]")[k]), mm(t.column("z[m]")[k])});
  }
  return out;
}

}  // namespace

std::string replayModelJson(const sim::Plant& plant, const planning::TerrainModel& regions,
                            const std::string& regions_source) {
  const mjModel* m = plant.mujocoModel();
  json bodies = json::array();
  for (int b = 0; b < m->nbody; ++b) {
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    json joints = json::array();
    for (int j = m->body_jntadr[b]; j >= 0 && j < m->body_jntadr[b] + m->body_jntnum[b]; ++j) {
      const char* jname = mj_id2name(m, mjOBJ_JOINT, j);
      const std::string n = jname != nullptr ? jname : "";
      const int type = m->jnt_type[j];
      const char* kind = type == mjJNT_FREE    ? "free"
                         : type == mjJNT_HINGE ? "hinge"
                         : type == mjJNT_SLIDE ? "slide"
                                               : "ball";
      json joint{{"name", n},
                 {"type", kind},
                 {"axis", vec(m->jnt_axis + 3 * j, 3)},
                 {"pos", vec(m->jnt_pos + 3 * j, 3)}};
      if (type == mjJNT_HINGE) joint["column"] = "q_" + n + "[rad]";
      if (type == mjJNT_SLIDE) joint["column"] = "q_" + n + "[m]";
      joints.push_back(joint);
    }
    bodies.push_back({{"name", name != nullptr ? name : ""},
                      {"parent", m->body_parentid[b]},
                      {"pos", vec(m->body_pos + 3 * b, 3)},
                      {"quat", vec(m->body_quat + 4 * b, 4)},
                      {"joints", joints}});
  }
  json geoms = json::array(), meshes = json::object();
  for (int g = 0; g < m->ngeom; ++g) {
    const char* type = geomTypeName(m->geom_type[g]);
    const float* rgba =
        m->geom_matid[g] >= 0 ? m->mat_rgba + 4 * m->geom_matid[g] : m->geom_rgba + 4 * g;
    if (type == nullptr || rgba[3] <= 0.0f || m->geom_group[g] > 2) continue;  // not shown
    json geom{{"body", m->geom_bodyid[g]},
              {"type", type},
              {"size", vec(m->geom_size + 3 * g, 3)},
              {"pos", vec(m->geom_pos + 3 * g, 3)},
              {"quat", vec(m->geom_quat + 4 * g, 4)},
              {"rgba", {rgba[0], rgba[1], rgba[2], rgba[3]}}};
    if (m->geom_type[g] == mjGEOM_MESH) {
      const int id = m->geom_dataid[g];
      const std::string key = std::to_string(id);
      geom["mesh"] = key;
      if (!meshes.contains(key)) {
        json v = json::array(), f = json::array();
        for (int i = 0; i < 3 * m->mesh_vertnum[id]; ++i) {
          v.push_back(m->mesh_vert[3 * m->mesh_vertadr[id] + i]);
        }
        for (int i = 0; i < 3 * m->mesh_facenum[id]; ++i) {
          f.push_back(m->mesh_face[3 * m->mesh_faceadr[id] + i]);
        }
        meshes[key] = {{"vertices", v}, {"faces", f}};
      }
    }
    geoms.push_back(geom);
  }
  json regs = json::array();
  for (const planning::ConvexRegion& r : regions.regions()) {
    json polygon = json::array();
    for (const Eigen::Vector2d& p : r.vertices) {
      // The surface plane through the centroid at its height.
      const double z = r.height - (r.normal.x() * (p.x() - r.centroid.x()) +
                                   r.normal.y() * (p.y() - r.centroid.y())) /
                                      r.normal.z();
      polygon.push_back({p.x(), p.y(), z});
    }
    regs.push_back(polygon);
  }
  json contacts = json::array();
  for (const sim::PlantLayout::Leg& leg : plant.layout().legs) {
    const int body = mj_name2id(m, mjOBJ_BODY, leg.contact_frame.c_str());
    if (body >= 0) contacts.push_back({{"name", leg.name}, {"body", body}});
  }
  const json out{{"format", "rollstep replay 1"},
                 {"robot_file", plant.robotFile()},
                 {"bodies", bodies},
                 {"geoms", geoms},
                 {"meshes", meshes},
                 {"contacts", contacts},
                 {"regions", regs},
                 {"regions_source", regions_source}};
  return out.dump() + "\n";
}

std::string replayScriptPath() {
  if (const char* s = std::getenv("ROLLSTEP_REPLAY_SCRIPT"); s != nullptr && *s != '\0') return s;
  return ROLLSTEP_REPLAY_SCRIPT;
}

void writeReplayPage(const std::string& run_dir, const std::string& page, const std::string& title,
                     const std::string& map_dir) {
  const std::string model_path = run_dir + "/replay.json";
  json model;
  try {
    model = json::parse(readAll(model_path, "replay model"));
  } catch (const json::exception& e) {
    throw std::runtime_error("replay model '" + model_path + "': " + e.what());
  }
  if (!model.is_object() || model.value("format", "") != "rollstep replay 1") {
    throw std::runtime_error("replay model '" + model_path +
                             "': not a rollstep replay file (format 'rollstep replay 1')");
  }
  const LogTable log = LogTable::read(run_dir + "/log.csv");
  if (!log.has("time[s]") || log.rows() == 0) {
    throw std::runtime_error("log '" + run_dir + "/log.csv': no rows or no time[s] column");
  }
  const std::vector<double>& t = log.column("time[s]");
  const double dt = t.size() > 1 ? (t.back() - t.front()) / static_cast<double>(t.size() - 1) : 1;
  // 50 frames per second at most: smooth enough, small enough.
  const std::size_t stride =
      dt > 0 ? std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(0.02 / dt - 1e-9))) : 1;
  json data{{"title", title}, {"model", model}, {"log", columnsOf(log, stride, 1e5)}};
  data["plan"] = nullptr;
  if (const std::string path = run_dir + "/plan.csv.gz"; fs::exists(path)) {
    data["plan"] =
        compactPlan(LogTable::parse(readGzipTextFile(path, "plan"), "plan '" + path + "'"), path);
  } else if (const std::string old = run_dir + "/plan.csv"; fs::exists(old)) {
    data["plan"] = compactPlan(LogTable::read(old, "plan"), old);  // an older run's
  }
  if (!map_dir.empty() && !fs::exists(map_dir + "/maps.csv")) {
    throw std::runtime_error("map log '" + map_dir +
                             "': no maps.csv (a folder written by rollstep sim --log-map)");
  }
  data["maps"] = mapSnapshots(map_dir.empty() ? run_dir + "/map" : map_dir);
  data["terrains"] = terrainVersions(run_dir + "/terrains.csv");
  const std::string script = replayScriptPath();
  const std::string code = readAll(script, "replay page script (build the target replay_script)");
  std::string text = data.dump();
  // Inside <script>: no "</script>" may end it early.
  for (std::size_t p = text.find("</"); p != std::string::npos; p = text.find("</", p + 3)) {
    text.replace(p, 2, "<\\/");
  }
  std::string escaped_title;
  for (char c : title) {
    if (c == '<')
      escaped_title += "&lt;";
    else if (c == '&')
      escaped_title += "&amp;";
    else
      escaped_title += c;
  }
  const std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>Replay: " +
      escaped_title +
      "</title>\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      "</head>\n<body>\n<script>window.ROLLSTEP_REPLAY = " +
      text + ";</script>\n<script src=\"replay.js\"></script>\n</body>\n</html>\n";
  const fs::path dir = fs::absolute(page).parent_path();
  writeFileAtomically((dir / "replay.js").string(), code);
  writeFileAtomically(page, html);
}

}  // namespace rollstep::experiments
