// OpenCL runtime: device choice, the program built from the embedded kernels (cached on disk by
// a hash of platform, device, options and source), one dispatch helper that names every launch
// for profiling and error messages, and the device-side scan.
#pragma once

#include <CL/opencl.hpp>
#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "core/device/device.h"
#include "core/device/stage.h"
#include "kernels/layout.h"

namespace vismap {

// The embedded kernel files (path, text) in the program's order: CMakeLists.txt's
// VISMAP_KERNEL_FILES, the shared layout first, then helpers, then one file per stage.
const std::vector<std::pair<std::string, std::string>>&
kernel_sources();  // generated at build time

// The OpenCL C program every device builds: the embedded kernel files, concatenated in
// that order. Built with "-cl-std=CL1.2 -DVM_MAXL=<lines per fragment>".
std::string program_source();

class ClRuntime {
 public:
  explicit ClRuntime(const std::string& device_spec);
  // Waits for the queue before the members go: a device may run queued commands as late as the
  // queue's release (Oclgrind does), and they read pending_writes_ and write into host_words_.
  ~ClRuntime();
  ClRuntime(const ClRuntime&) = delete;
  ClRuntime& operator=(const ClRuntime&) = delete;

  const DeviceInfo& info() const { return info_; }
  cl::Context& context() { return ctx_; }
  cl::CommandQueue& queue() { return queue_; }

  // Builds (or loads from the cache) the program with -DVM_MAXL=maxl; kernels by name.
  void build(uint32_t maxl);
  uint32_t maxl() const { return maxl_; }
  struct Kernel {
    cl::Kernel k;
    cl_uint args = 0;  // CL_KERNEL_NUM_ARGS
  };
  Kernel& kernel(const char* name);

  // Enqueues kernel `name` over n work-items (rounded up to the work-group multiple) with the
  // given arguments, recording its event under `stage`. The argument count must be the
  // kernel's (CL_KERNEL_NUM_ARGS); any failure is a DeviceError naming kernel and stage.
  template <class... Args>
  void launch(Stage stage, const char* name, size_t n, const Args&... args) {
    launch_grouped(stage, name, n, 0, args...);
  }
  // The same in work-groups of `local` items (0: the default size).
  template <class... Args>
  void launch_grouped(Stage stage, const char* name, size_t n, size_t local, const Args&... args) {
    if (n == 0) return;
    Kernel& k = kernel(name);
    check_arity(k, stage, name, sizeof...(Args));
    pending_bytes_ = 0;
    set_args(k, stage, name, 0, args...);
    enqueue(stage, name, k.k, n, local);
  }
  void enqueue(Stage stage, const char* name, cl::Kernel& k, size_t n, size_t local);

  cl::Buffer alloc(size_t bytes, const char* what);
  template <class T>
  cl::Buffer upload(const std::vector<T>& v, const char* what) {
    cl::Buffer b = alloc(std::max<size_t>(v.size() * sizeof(T), sizeof(T)), what);
    if (!v.empty()) queue_.enqueueWriteBuffer(b, CL_TRUE, 0, v.size() * sizeof(T), v.data());
    write_bytes_ += v.size() * sizeof(T);
    return b;
  }
  void fill_u32(cl::Buffer& b, uint32_t value, size_t count, Stage stage);
  // Blocking read: the host waits for the queue to drain and the copy (one round trip, ~50 us
  // on PoCL here, ~16-19 us on an H100). Counted under `stage`: host_syncs() and the stage's
  // syncs and transfer bytes since reset_profile().
  void read(Stage stage, const cl::Buffer& b, size_t offset, size_t bytes, void* dst);
  // Non-blocking read (done by the next blocking read or collect_profile, the queue being in
  // order): counted as transfer bytes only.
  void read_async(Stage stage, const cl::Buffer& b, size_t offset, size_t bytes, void* dst);
  // Makes every earlier read_async complete: free when a blocking read (or collect_profile) came
  // after the last of them, else one wait for the queue, counted as a blocking read of `stage`.
  void complete_reads(Stage stage);
  // Waits for every queued command, uncounted and without throwing: before the host memory of a
  // read_async or of a non-blocking write goes out of scope on a throw (and in the destructor).
  void drain() noexcept;
  // Host words owned by the runtime (resized to n), for a read_async target that must outlive
  // the caller's frame (a stage that throws before the next blocking read leaves no read into
  // freed memory). One user at a time: the silhouettes' group totals.
  std::vector<uint32_t>& host_words(size_t n) {
    host_words_.resize(n);
    return host_words_;
  }
  // Device-side copy, recorded as a launch of `stage` ("copy") that moves 2 x bytes.
  void copy(Stage stage, const cl::Buffer& src, cl::Buffer& dst, size_t bytes);
  uint32_t host_syncs() const { return syncs_; }
  // Bytes written host -> device by upload() since reset_profile() (a frame's camera and cull
  // modes; the scene's upload happens before the reset).
  uint64_t write_bytes() const { return write_bytes_; }

  // Exclusive scan of n counts into offsets (device), returning the total (one read back).
  uint32_t scan(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n);
  // The offsets only, for a caller that knows the total (no read back).
  void scan_offsets(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n);
  // Same, without reading back: the total lands in totals[slot].
  void scan_to(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n, cl::Buffer& totals,
               uint32_t slot);
  // A fused scan's work-group totals (scan.cl vm_group_offset, vm_group_base; issue 17): a
  // producer over n items in work-groups of VM_SCAN_WG writes each item's offset within its
  // group and each group's total; the host, which reads the totals for the count anyway, writes
  // each group's base (the totals before it) without blocking; the consumer, over the same items
  // and groups, adds its group's base, so no scan launch runs between them. A consumer takes
  // (bases, groups); groups 0 means the offsets are already global.
  struct GroupSums {
    cl::Buffer sums, bases;
    uint32_t groups = 0;
  };
  GroupSums group_sums(uint32_t n, const char* what);
  // The producer's total: one blocking read of the group totals, then set_bases.
  uint32_t group_total(Stage stage, GroupSums& g);
  // Writes g's bases from its groups' totals (read by the caller) without blocking; returns
  // their sum, the producer's total.
  uint32_t set_bases(GroupSums& g, const std::vector<uint32_t>& sums);

  // Profiling: per-stage event times since the last collect (waits for the queue).
  // bytes: the launches' modelled device traffic, each launch counting the sizes of the
  // buffers passed to it once (fills and copies: the bytes they write, or read and write);
  // syncs and transfer_bytes: the stage's blocking reads and its device -> host bytes.
  struct StageTime {
    double ms = 0;
    uint32_t launches = 0;
    uint32_t syncs = 0;
    uint64_t bytes = 0;
    uint64_t transfer_bytes = 0;
  };
  using StageTimes = std::array<StageTime, kStageCount>;
  void reset_profile();
  StageTimes collect_profile();
  // The same event times per "stage/kernel" (fills are "stage/fill"), summed over every
  // collect_profile() since reset_profile().
  const std::map<std::string, std::pair<double, uint32_t>>& kernel_profile() const {
    return kernel_profile_;
  }
  // Device memory: the sum of every allocation since reset_allocated() (an upper bound), and
  // the most held at once since reset_peak() (a buffer's bytes count until the runtime releases
  // it, which may be after its last handle goes).
  uint64_t allocated_bytes() const { return allocated_; }
  void reset_allocated() { allocated_ = 0; }
  uint64_t peak_bytes() const { return peak_; }
  void reset_peak() { peak_ = live_->load(); }

 private:
  template <class A, class... Rest>
  void set_args(Kernel& k, Stage stage, const char* name, cl_uint i, const A& a,
                const Rest&... rest) {
    if constexpr (std::is_same_v<A, cl::Buffer>)  // a null buffer (an unused optional) counts 0
      if (a() != nullptr) pending_bytes_ += a.template getInfo<CL_MEM_SIZE>();
    try {
      k.k.setArg(i, a);
    } catch (const cl::Error& e) {
      throw_arg_error(stage, name, i, e.err());
    }
    set_args(k, stage, name, i + 1, rest...);
  }
  void set_args(Kernel&, Stage, const char*, cl_uint) {}
  void check_arity(const Kernel& k, Stage stage, const char* name, size_t given) const;
  [[noreturn]] void throw_arg_error(Stage stage, const char* name, cl_uint arg, cl_int err) const;
  // Scans n > 0 counts into offsets and writes the total to total[slot] (1 launch for at most
  // VM_SCAN_BLOCK counts, 2 for at most VM_SCAN_FINISH_MAX blocks; scan.cl).
  void scan_level(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n,
                  cl::Buffer& total, uint32_t slot);

  DeviceInfo info_;
  cl::Platform platform_;
  cl::Device device_;
  cl::Context ctx_;
  cl::CommandQueue queue_;
  cl::Program program_;
  uint32_t maxl_ = 0;
  std::map<std::string, Kernel> kernels_;
  struct Launch {
    Stage stage;
    const char* name;  // kernel name, "fill" or "copy" (string literals only)
    cl::Event event;
    uint64_t bytes;  // modelled device traffic (StageTime::bytes)
  };
  std::vector<Launch> launches_;
  std::map<std::string, std::pair<double, uint32_t>> kernel_profile_;
  uint64_t allocated_ = 0;
  // Shared with the release callbacks, which may run after the runtime is gone.
  std::shared_ptr<std::atomic<uint64_t>> live_ = std::make_shared<std::atomic<uint64_t>>(0);
  bool host_blocks_ =
      false;  // large buffers on host blocks: CPU devices, unless $VISMAP_HOST_BLOCKS=0
  uint64_t peak_ = 0;
  uint32_t syncs_ = 0;
  bool async_pending_ = false;  // a read_async not yet followed by a blocking read
  std::vector<uint32_t> host_words_;
  // Host data of non-blocking writes, kept until the queue has drained (a blocking read,
  // complete_reads or collect_profile).
  std::vector<std::vector<uint32_t>> pending_writes_;
  uint64_t pending_bytes_ = 0;  // buffer sizes of the launch being set up
  uint64_t write_bytes_ = 0;
  std::array<uint32_t, kStageCount> stage_syncs_{};
  std::array<uint64_t, kStageCount> stage_transfer_{};
  cl::Buffer scratch_total_;
};

// Hands the freed host blocks of 32 MiB and more that CPU devices keep for reuse back to the
// kernel (every Renderer's); returns their bytes. Safe from any thread.
uint64_t release_host_blocks();

}  // namespace vismap
