#pragma once
// A fresh directory under /tmp for one test's files, removed with everything
// in it when the test ends (also when it fails).
#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

namespace lockstep::testing {

class scratch_directory {
 public:
  // prefix: the directory's name before the random part, e.g. "lockstep-run-test".
  explicit scratch_directory(const std::string& prefix = "lockstep-test") {
    std::string name = "/tmp/" + prefix + "-XXXXXX";
    if (::mkdtemp(name.data()) == nullptr) throw std::runtime_error("mkdtemp failed for " + name);
    path_ = name;
  }
  ~scratch_directory() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  scratch_directory(const scratch_directory&) = delete;  // owns the directory
  scratch_directory& operator=(const scratch_directory&) = delete;
  const std::filesystem::path& path() const noexcept { return path_; }
  // The path of a file in it, as a string.
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // The names of what it holds now, in directory order.
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(path_)) names.push_back(entry.path().filename().string());
    return names;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace lockstep::testing
