// Shared entry point of the rollstep benchmarks: Google Benchmark's own main, plus what a
// reader needs to compare figures across machines (the SIMD instruction sets Eigen was
// compiled for, the build type), and a loud warning when the code was built without
// optimisation-level NDEBUG (a Debug build measures nothing useful).
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <cstdio>

int main(int argc, char** argv) {
#ifdef NDEBUG
  benchmark::AddCustomContext("rollstep_build", "release (NDEBUG)");
#else
  benchmark::AddCustomContext("rollstep_build", "DEBUG: figures are meaningless");
  std::fprintf(stderr,
               "\n*** rollstep: this benchmark was built without NDEBUG (not Release). ***\n"
               "*** Rebuild with -DCMAKE_BUILD_TYPE=Release before reading any figure. ***\n\n");
#endif
  benchmark::AddCustomContext("eigen_simd", Eigen::SimdInstructionSetsInUse());
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
