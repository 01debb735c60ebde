#pragma once
// The fuzzers' input written to a file, for readers that take a path (strata::LoadPointCloud):
// one file per process in /dev/shm (memory) when it exists, rewritten for every input.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace strata::fuzz {

/// Writes `size` bytes to this process's input file with `extension` (".pcd") and returns
/// its path.
inline std::string WriteInput(const std::uint8_t* data, std::size_t size,
                              const std::string& extension) {
  namespace fs = std::filesystem;
  static const fs::path dir = [] {
    const fs::path base =
        fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
    fs::path made = base / ("strata-fuzz-" + std::to_string(getpid()));
    fs::create_directories(made);
    return made;
  }();
  const std::string path = (dir / ("input" + extension)).string();
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace strata::fuzz
