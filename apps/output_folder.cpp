#include "output_folder.hpp"

#include <cstdio>
#include <filesystem>
#include <system_error>
#include <utility>

#include "rollstep/common/interrupt.hpp"
#include "rollstep/common/text_file.hpp"

namespace rollstep::apps {

namespace fs = std::filesystem;

OutputFolder::OutputFolder(std::string command, std::string dir, std::vector<std::string> outputs)
    : command_(std::move(command)), dir_(std::move(dir)), outputs_(std::move(outputs)) {}

void OutputFolder::create() const {
  std::error_code ec;
  if (fs::exists(dir_, ec) && !fs::is_directory(dir_, ec)) {
    throw OutputError("--out '" + dir_ + "': exists and is not a directory");
  }
  fs::create_directories(dir_, ec);
  if (ec) throw OutputError("--out '" + dir_ + "': cannot create the directory: " + ec.message());
}

void OutputFolder::begin() const {
  deferInterrupts();
  throwIfInterrupted();
  removeOutputs(true);
  std::error_code ec;
  fs::remove(failedPath(), ec);
  if (ec) {
    throw OutputError("cannot remove the previous run's '" + failedPath() + "': " + ec.message());
  }
}

void removeStaleTemporaries(const std::string& dir, const std::vector<std::string>& outputs) {
  std::error_code ec;
  std::vector<fs::path> stale;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string file = entry.path().filename().string();
    if (file.empty() || file[0] != '.' || file.find(".tmp.") == std::string::npos) continue;
    for (const std::string& name : outputs) {
      const bool prefix = !name.empty() && name.back() == '*';
      const std::string start = "." + (prefix ? name.substr(0, name.size() - 1) : name + ".tmp.");
      if (file.rfind(start, 0) == 0) stale.push_back(entry.path());
    }
  }
  for (const fs::path& p : stale) fs::remove(p, ec);
}

void OutputFolder::removeOutputs(bool throw_on_error) const {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const std::string& name : outputs_) {
    if (name.empty() || name.back() != '*') {
      files.push_back(fs::path(dir_) / name);
      continue;
    }
    const std::string prefix = name.substr(0, name.size() - 1);
    for (const auto& entry : fs::directory_iterator(dir_, ec)) {
      if (entry.path().filename().string().rfind(prefix, 0) == 0) files.push_back(entry.path());
    }
  }
  if (throw_on_error) {  // at the start: a killed run's (kill -9) temporaries go too
    std::vector<std::string> names = outputs_;
    names.push_back("FAILED");
    removeStaleTemporaries(dir_, names);
  }
  for (const fs::path& f : files) {
    fs::remove(f, ec);
    if (ec && throw_on_error) {
      throw OutputError("cannot remove the previous run's '" + f.string() + "': " + ec.message());
    }
  }
}

bool OutputFolder::fail(const std::string& reason) const noexcept {
  try {
    removeOutputs(false);
    writeFileAtomically(failedPath(), "rollstep " + command_ + " failed: " + reason + "\n");
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rollstep: warning: %s\n", e.what());
    return false;
  }
}

}  // namespace rollstep::apps
