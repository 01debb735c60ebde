// libFuzzer target: strata::LoadPointCloud on a file of the extension this target is built for
// (STRATA_FUZZ_EXTENSION: ".pcd", ".ply", or, for OctoMap, the first byte choosing ".bt" or
// ".ot"), with the limits strata-server reads files with. Whatever the bytes, the loader
// returns a cloud or an error: a crash, an abort (Debian's PCL asserts), a leak or a hang is a
// finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_file.hpp"
#include "strata/cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string extension = STRATA_FUZZ_EXTENSION;
  if (extension == ".octomap") {
    if (size == 0) return 0;
    extension = (data[0] & 1) != 0 ? ".bt" : ".ot";
    ++data;
    --size;
  }
  strata::CloudLoadLimits limits;  // The server's (--max-points 50 M, 4 GiB files).
  const strata::Expected<strata::LoadedCloud> cloud =
      strata::LoadPointCloud(strata::fuzz::WriteInput(data, size, extension), limits);
  if (cloud.ok()) {
    // A cloud the loader returns holds finite points only, within the coordinate bound.
    for (const Eigen::Vector3f& p : cloud->points) {
      if (!p.allFinite() || p.cwiseAbs().maxCoeff() > limits.max_abs_coordinate_m) __builtin_trap();
    }
    if (cloud->points.size() + cloud->dropped_nonfinite != cloud->raw_point_count) __builtin_trap();
  }
  return 0;
}
