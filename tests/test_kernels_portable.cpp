// The kernels as OpenCL C 1.2 for an NVIDIA GPU, compiled by clang's front end and NVPTX back end
// (target nvptx64-nvidia-nvcl). CI has PoCL only, whose compiler accepts things a GPU driver may
// not; this catches, without a GPU, source that only PoCL would build: a missing extension,
// a type or builtin the target lacks, an implicit conversion the language forbids. It is not
// NVIDIA's own compiler (NVVM), so a pass here does not prove the driver builds the program.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/device/cl_runtime.h"

namespace {

namespace fs = std::filesystem;

TEST(Kernels, CompileAsOpenCL12ForNvptx) {
#ifndef VISMAP_CLANG_CL
  GTEST_SKIP() << "no clang found at configure time";
#else
  const fs::path dir = fs::temp_directory_path() / ("vismap_nvptx_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path src = dir / "program.cl";
  std::ofstream(src) << vismap::program_source();
  // The line counts the pipeline builds with: 8 at first, doubled when fragments need more.
  for (int maxl : {8, 16, 32}) {
    const fs::path log = dir / "clang.log";
    // __OPENCL_VERSION__ is the device's version, which a driver defines and clang does not.
    const std::string cmd = std::string(VISMAP_CLANG_CL) +
                            " -cl-std=CL1.2 -x cl -Xclang -finclude-default-header"
                            " -target nvptx64-nvidia-nvcl -D__OPENCL_VERSION__=120 -DVM_MAXL=" +
                            std::to_string(maxl) + " -O1 -Werror -S -o " +
                            (dir / "program.ptx").string() + " " + src.string() + " > " +
                            log.string() + " 2>&1";
    const int rc = std::system(cmd.c_str());
    std::ifstream in(log);
    const std::string out((std::istreambuf_iterator<char>(in)), {});
    EXPECT_EQ(rc, 0) << "VM_MAXL=" << maxl << ":\n" << out;
    std::ifstream ptx(dir / "program.ptx");
    const std::string code((std::istreambuf_iterator<char>(ptx)), {});
    // Every kernel made it to the back end: count the entry points against the source's.
    size_t entries = 0, kernels = 0;
    for (size_t at = code.find(".entry"); at != std::string::npos; at = code.find(".entry", at + 1))
      ++entries;
    const std::string source = vismap::program_source();
    for (size_t at = source.find("__kernel "); at != std::string::npos;
         at = source.find("__kernel ", at + 1))
      ++kernels;
    EXPECT_GT(kernels, 30u);
    EXPECT_EQ(entries, kernels) << "VM_MAXL=" << maxl;
  }
  fs::remove_all(dir);
#endif
}

}  // namespace
