// libFuzzer target: strata::LoadPointCloud on a file of the extension this target is built for
// (STRATA_FUZZ_EXTENSION: ".pcd", ".ply", or, for OctoMap, the first byte choosing ".bt" or
// ".ot"). Whatever the bytes, the loader returns a cloud or an error: a crash, an abort
// (Debian's PCL asserts), a leak or a hang is a finding. The point limit is 100,000 instead of
// the server's 50 M: the checks against it are the same code at any value, and an OctoMap input
// that expands a pruned tree to millions of points took tens of milliseconds each (205 inputs
// a second), so that a long run saw few inputs.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_file.hpp"
#include "strata/io/cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string extension = STRATA_FUZZ_EXTENSION;
  if (extension == ".octomap") {
    if (size == 0) return 0;
    extension = (data[0] & 1) != 0 ? ".bt" : ".ot";
    ++data;
    --size;
  }
  strata::CloudLoadLimits limits;
  limits.max_points = 100'000;
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
