#include "core/device/cl_runtime.h"

#include <sys/mman.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <numeric>
#include <sstream>

#include "core/error.h"

namespace vismap {

namespace {

constexpr size_t kLocal = 64;

const char* cl_error_name(cl_int err) {
  switch (err) {
    case CL_OUT_OF_RESOURCES:
      return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY:
      return "CL_OUT_OF_HOST_MEMORY";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE:
      return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_INVALID_VALUE:
      return "CL_INVALID_VALUE";
    case CL_INVALID_MEM_OBJECT:
      return "CL_INVALID_MEM_OBJECT";
    case CL_INVALID_KERNEL:
      return "CL_INVALID_KERNEL";
    case CL_INVALID_ARG_INDEX:
      return "CL_INVALID_ARG_INDEX";
    case CL_INVALID_ARG_VALUE:
      return "CL_INVALID_ARG_VALUE";
    case CL_INVALID_ARG_SIZE:
      return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_KERNEL_ARGS:
      return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_WORK_GROUP_SIZE:
      return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_WORK_ITEM_SIZE:
      return "CL_INVALID_WORK_ITEM_SIZE";
    case CL_INVALID_GLOBAL_WORK_SIZE:
      return "CL_INVALID_GLOBAL_WORK_SIZE";
    case CL_INVALID_BUFFER_SIZE:
      return "CL_INVALID_BUFFER_SIZE";
    case CL_INVALID_COMMAND_QUEUE:
      return "CL_INVALID_COMMAND_QUEUE";
    default:
      return "OpenCL error";
  }
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

uint64_t fnv1a(const std::string& s, uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::filesystem::path cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x)
    return std::filesystem::path(x) / "vismap";
  if (const char* h = std::getenv("HOME"); h && *h)
    return std::filesystem::path(h) / ".cache" / "vismap";
  return {};
}

struct Found {
  cl::Platform platform;
  cl::Device device;
  DeviceInfo info;
};

std::vector<Found> enumerate() {
  std::vector<Found> out;
  std::vector<cl::Platform> platforms;
  // With exceptions on, a loader that finds no ICD file throws (CL_PLATFORM_NOT_FOUND_KHR)
  // instead of returning: no platform is "no device", said plainly by pick().
  try {
    if (cl::Platform::get(&platforms) != CL_SUCCESS) return out;
  } catch (const cl::Error&) {
    return out;
  }
  for (size_t p = 0; p < platforms.size(); ++p) {
    std::vector<cl::Device> devices;
    try {
      platforms[p].getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue;
    }
    for (size_t d = 0; d < devices.size(); ++d) {
      Found f{platforms[p], devices[d], {}};
      f.info.platform = platforms[p].getInfo<CL_PLATFORM_NAME>();
      f.info.name = devices[d].getInfo<CL_DEVICE_NAME>();
      f.info.version = devices[d].getInfo<CL_DEVICE_VERSION>();
      f.info.is_gpu = (devices[d].getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) != 0;
      f.info.id = std::to_string(p) + ":" + std::to_string(d);
      out.push_back(f);
    }
  }
  return out;
}

Found pick(const std::string& requested) {
  std::vector<Found> all = enumerate();
  if (all.empty()) throw DeviceError("no OpenCL device found (is pocl-opencl-icd installed?)");
  std::string spec = requested;
  if (spec.empty())
    if (const char* env = std::getenv("VISMAP_DEVICE"); env && *env) spec = env;
  if (spec.empty()) {
    for (const Found& f : all)
      if (f.info.is_gpu) return f;
    return all.front();
  }
  for (const Found& f : all)
    if (f.info.id == spec) return f;
  std::string want = lower(spec);
  for (const Found& f : all)
    if (lower(f.info.name).find(want) != std::string::npos ||
        lower(f.info.platform).find(want) != std::string::npos)
      return f;
  std::string names;
  for (const Found& f : all)
    names += "\n  " + f.info.id + " " + f.info.platform + " / " + f.info.name;
  throw DeviceError("no OpenCL device matches '" + spec + "'; devices:" + names);
}

}  // namespace

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  for (const Found& f : enumerate()) out.push_back(f.info);
  return out;
}

ClRuntime::ClRuntime(const std::string& device_spec) {
  Found f = pick(device_spec);
  platform_ = f.platform;
  device_ = f.device;
  info_ = f.info;
  ctx_ = cl::Context(device_);
  queue_ = cl::CommandQueue(ctx_, device_, CL_QUEUE_PROFILING_ENABLE);
  const char* blocks = std::getenv("VISMAP_HOST_BLOCKS");
  host_blocks_ = (device_.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU) &&
                 !(blocks && std::string(blocks) == "0");
  scratch_total_ = cl::Buffer(ctx_, CL_MEM_READ_WRITE, sizeof(uint32_t));
}

ClRuntime::~ClRuntime() {
  // Without this the members died first (pending_writes_ is declared after queue_): a frame that
  // threw with commands still queued left a non-blocking write to read freed memory when the
  // queue's release ran it (issue 51: oclgrind's "Invalid write of size 64" in clip_fill).
  drain();
}

void ClRuntime::drain() noexcept {
  try {
    if (queue_()) queue_.finish();
  } catch (...) {
    // A device that fails here has nothing left to run.
  }
  async_pending_ = false;
  pending_writes_.clear();
}

std::string program_source() {
  std::string source;
  for (const auto& [file, text] : kernel_sources())
    source += "/* ---- " + file + " ---- */\n" + text + "\n";
  return source;
}

void ClRuntime::build(uint32_t maxl) {
  if (maxl == maxl_ && program_()) return;
  const std::string source = program_source();
  std::string options = "-cl-std=CL1.2 -DVM_MAXL=" + std::to_string(maxl);
  // A CPU device runs a work-group's items in loops between barriers (PoCL): there one item
  // scans the group serially, two barriers instead of sixteen (scan.cl vm_group_scan).
  if (device_.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU) options += " -DVM_SERIAL_GROUP_SCAN";
  // Oclgrind (the device simulator, scripts/oclgrind_check.sh) builds with LLVM 14, whose inliner
  // marks the noalias of a struct returned by value (sret) with llvm.experimental.noalias.scope
  // .decl, an intrinsic Oclgrind 21.10 cannot run ("Undefined external function" when creating
  // leaf_bin, which inlines leaf_walk). Unoptimised, nothing is inlined, and the simulator checks
  // the code as written.
  if (info_.platform.find("Oclgrind") != std::string::npos) options += " -cl-opt-disable";
  if (const char* extra = std::getenv("VISMAP_CL_OPTIONS"); extra && *extra)
    options += std::string(" ") + extra;
  uint64_t key =
      fnv1a(source, fnv1a(options, fnv1a(info_.platform + "|" + info_.name + "|" + info_.version +
                                         "|" + device_.getInfo<CL_DRIVER_VERSION>())));
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(key));
  std::filesystem::path dir = cache_dir(),
                        file = dir.empty() ? dir : dir / (std::string(hex) + ".bin");

  cl::Program program;
  bool built = false;
  if (!file.empty() && std::filesystem::exists(file)) {
    std::ifstream in(file, std::ios::binary);
    std::vector<unsigned char> bin((std::istreambuf_iterator<char>(in)), {});
    try {
      cl::Program::Binaries bins{bin};
      program = cl::Program(ctx_, {device_}, bins);
      program.build({device_}, options.c_str());
      built = true;
    } catch (const cl::Error&) {
      built = false;  // stale or foreign cache entry: rebuild from source
    }
  }
  if (!built) {
    program = cl::Program(ctx_, source);
    try {
      program.build({device_}, options.c_str());
    } catch (const cl::Error&) {
      std::string log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_);
      throw DeviceError("OpenCL program build failed on " + info_.name + ":\n" + log);
    }
    if (!file.empty()) {
      try {
        auto bins = program.getInfo<CL_PROGRAM_BINARIES>();
        if (!bins.empty() && !bins[0].empty()) {
          std::filesystem::create_directories(dir);
          std::filesystem::path tmp = file;
          tmp += ".tmp" + std::to_string(::getpid());
          std::ofstream(tmp, std::ios::binary)
              .write(reinterpret_cast<const char*>(bins[0].data()),
                     static_cast<std::streamsize>(bins[0].size()));
          std::filesystem::rename(tmp, file);
        }
      } catch (...) {
        // The cache is an optimisation: a read-only home must not fail a render.
      }
    }
  }
  program_ = program;
  maxl_ = maxl;
  kernels_.clear();
}

ClRuntime::Kernel& ClRuntime::kernel(const char* name) {
  auto it = kernels_.find(name);
  if (it != kernels_.end()) return it->second;
  try {
    Kernel k{cl::Kernel(program_, name)};
    k.args = k.k.getInfo<CL_KERNEL_NUM_ARGS>();
    return kernels_.emplace(name, std::move(k)).first->second;
  } catch (const cl::Error& e) {
    throw DeviceError(std::string("kernel '") + name + "' not found in the program: " + e.what());
  }
}

void ClRuntime::check_arity(const Kernel& k, Stage stage, const char* name, size_t given) const {
  if (given != k.args)
    throw DeviceError(std::string("launch of ") + name + " (stage " + stage_name(stage) +
                      ") with " + std::to_string(given) + " arguments; the kernel takes " +
                      std::to_string(k.args));
}

void ClRuntime::throw_arg_error(Stage stage, const char* name, cl_uint arg, cl_int err) const {
  throw DeviceError(std::string("launch of ") + name + " (stage " + stage_name(stage) +
                    "): argument " + std::to_string(arg) + " refused: " + cl_error_name(err) +
                    " (" + std::to_string(err) + ") on " + info_.name);
}

void ClRuntime::enqueue(Stage stage, const char* name, cl::Kernel& k, size_t n, size_t local) {
  size_t l = local ? local : kLocal;
  size_t global = (n + l - 1) / l * l;
  cl::Event ev;
  try {
    queue_.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(global), cl::NDRange(l), nullptr,
                                &ev);
  } catch (const cl::Error& e) {
    throw DeviceError(std::string("launch of ") + name + " (stage " + stage_name(stage) + ", " +
                      std::to_string(n) + " items) failed: " + cl_error_name(e.err()) + " (" +
                      std::to_string(e.err()) + ") on " + info_.name);
  }
  launches_.push_back({stage, name, ev, pending_bytes_});
  pending_bytes_ = 0;
}

namespace {
// Host memory behind the large device buffers of a CPU device (PoCL runs kernels on host
// memory; the buffers are created with CL_MEM_USE_HOST_PTR), aligned to 2 MiB huge pages and
// advised to use them (madvise). A fresh 4 KiB page costs a page fault on first touch, ~11 us on
// the CI machine (256 MB: 740 ms); a huge page costs about as much for 512 times the memory
// (256 MB: 23 ms). Blocks under 32 MiB come from the C allocator, which keeps freed ones for
// reuse (keep_freed_memory_for_reuse). Bigger ones are mmaps kept in FreeBlocks when released, for
// the next buffers to reuse without faults, until release_freed_memory() hands them back to the
// kernel (vismapd: after a session or a refused request; issue 35). Taken fresh from mmap every
// frame, the dragon's frame at 1080p took 1.1-3.2 times as long on the shared 2-core machine.
constexpr size_t kHugePage = size_t(2) << 20;
constexpr size_t kHostBlockMinBytes = 1 << 20;  // smaller buffers are left to the runtime
constexpr size_t kMappedBlockBytes = size_t(32) << 20;

// Freed mapped blocks by size, process-wide: released from PoCL's threads (the buffer's
// destructor callback), taken by any Renderer. A buffer's callback may come after the release
// that should have caught its block (PoCL frees a buffer once the commands that use it are done,
// after a failed frame's host code has moved on): until the next take, blocks put back go
// straight to the kernel.
class FreeBlocks {
 public:
  // The smallest kept block of at least `bytes` (bytes becomes its size), or nullptr.
  void* take(size_t& bytes) {
    std::lock_guard lk(mu_);
    releasing_ = false;
    auto it = by_size_.lower_bound(bytes);
    if (it == by_size_.end()) return nullptr;
    bytes = it->first;
    void* p = it->second;
    by_size_.erase(it);
    return p;
  }
  void put(void* p, size_t bytes) {
    {
      std::lock_guard lk(mu_);
      if (!releasing_) {
        by_size_.emplace(bytes, p);
        return;
      }
    }
    ::munmap(p, bytes);
  }
  uint64_t release() {
    std::multimap<size_t, void*> all;
    {
      std::lock_guard lk(mu_);
      all.swap(by_size_);
      releasing_ = true;
    }
    uint64_t n = 0;
    for (auto [bytes, p] : all) {
      ::munmap(p, bytes);
      n += bytes;
    }
    return n;
  }

 private:
  std::mutex mu_;
  std::multimap<size_t, void*> by_size_;
  bool releasing_ = false;
};
FreeBlocks& free_blocks() {
  static FreeBlocks* b = new FreeBlocks;  // never destroyed: callbacks may run at exit
  return *b;
}

// Rounds bytes up to whole huge pages; nullptr on failure.
void* take_host_block(size_t& bytes) {
  bytes = (bytes + kHugePage - 1) / kHugePage * kHugePage;
  if (bytes >= kMappedBlockBytes) {
    if (void* p = free_blocks().take(bytes)) return p;
    // Mapped with a huge page of slack, then cut to an aligned block of `bytes`.
    void* m = ::mmap(nullptr, bytes + kHugePage, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (m == MAP_FAILED) return nullptr;
    const uintptr_t a = (reinterpret_cast<uintptr_t>(m) + kHugePage - 1) & ~(kHugePage - 1);
    const size_t head = a - reinterpret_cast<uintptr_t>(m);
    if (head) ::munmap(m, head);
    if (kHugePage - head) ::munmap(reinterpret_cast<char*>(a) + bytes, kHugePage - head);
    ::madvise(reinterpret_cast<void*>(a), bytes, MADV_HUGEPAGE);
    return reinterpret_cast<void*>(a);
  }
  void* p = std::aligned_alloc(kHugePage, bytes);
  if (p) ::madvise(p, bytes, MADV_HUGEPAGE);  // advice only: fine if the kernel says no
  return p;
}

void give_host_block(void* p, size_t bytes) {
  if (bytes >= kMappedBlockBytes)
    free_blocks().put(p, bytes);
  else
    std::free(p);
}

struct LiveRecord {
  std::shared_ptr<std::atomic<uint64_t>> live;
  uint64_t bytes;
  void* block = nullptr;  // the host block behind the buffer, if any
  size_t block_bytes = 0;
};
void CL_CALLBACK on_release(cl_mem, void* user) {
  auto* r = static_cast<LiveRecord*>(user);
  r->live->fetch_sub(r->bytes);
  if (r->block) give_host_block(r->block, r->block_bytes);
  delete r;
}
}  // namespace

uint64_t release_host_blocks() {
  return free_blocks().release();
}

cl::Buffer ClRuntime::alloc(size_t bytes, const char* what) {
  bytes = std::max<size_t>(bytes, 16);
  void* block = nullptr;
  size_t block_bytes = bytes;
  if (host_blocks_ && bytes >= kHostBlockMinBytes) {
    block = take_host_block(block_bytes);
    // No memory for the block: PoCL would try the same allocation itself and abort the process
    // when it fails (an assertion in pocl_create_migration_commands, issue 35, case 2), so the
    // buffer is refused here, as too large for this frame.
    if (!block)
      throw InputError(InputErrorKind::TooLarge, "", "", what, -1,
                       "no memory for " + std::to_string(bytes) + " bytes of device memory");
  }
  try {
    cl::Buffer b = block ? cl::Buffer(ctx_, CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR, bytes, block)
                         : cl::Buffer(ctx_, CL_MEM_READ_WRITE, bytes);
    allocated_ += bytes;
    auto* rec = new LiveRecord{live_, bytes, block, block_bytes};
    if (clSetMemObjectDestructorCallback(b(), on_release, rec) == CL_SUCCESS) {
      peak_ = std::max<uint64_t>(peak_, live_->fetch_add(bytes) + bytes);
    } else {
      // Without the callback the block could not be freed safely: leak it rather than free it
      // while the buffer may still be in use.
      delete rec;
    }
    return b;
  } catch (const cl::Error& e) {
    if (block) give_host_block(block, block_bytes);
    // A buffer larger than the device allows, or no memory for it, is the frame's size, not a
    // device fault: too large, as the host block above (a 10 GB fragment buffer was -61).
    if (e.err() == CL_INVALID_BUFFER_SIZE || e.err() == CL_MEM_OBJECT_ALLOCATION_FAILURE ||
        e.err() == CL_OUT_OF_HOST_MEMORY || e.err() == CL_OUT_OF_RESOURCES)
      throw InputError(InputErrorKind::TooLarge, "", "", what, -1,
                       "no device memory for " + std::to_string(bytes) + " bytes (" +
                           cl_error_name(e.err()) + ")");
    throw DeviceError(std::string("allocating ") + std::to_string(bytes) + " bytes for " + what +
                      " failed: " + e.what() + " (" + std::to_string(e.err()) + ")");
  }
}

void ClRuntime::fill_u32(cl::Buffer& b, uint32_t value, size_t count, Stage stage) {
  if (count == 0) return;
  cl::Event ev;
  try {
    queue_.enqueueFillBuffer(b, value, 0, count * sizeof(uint32_t), nullptr, &ev);
  } catch (const cl::Error& e) {
    throw DeviceError(std::string("fill of ") + std::to_string(count) + " words (stage " +
                      stage_name(stage) + ") failed: " + cl_error_name(e.err()) + " (" +
                      std::to_string(e.err()) + ")");
  }
  launches_.push_back({stage, "fill", ev, count * sizeof(uint32_t)});
}

void ClRuntime::scan_level(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n,
                           cl::Buffer& total, uint32_t slot) {
  const uint32_t blocks = static_cast<uint32_t>((n + VM_SCAN_BLOCK - 1) / VM_SCAN_BLOCK);
  if (blocks == 1) {  // one launch: the block's sum is the total
    launch_grouped(stage, "scan_blocks", VM_SCAN_WG, VM_SCAN_WG, counts, offsets, n, total, slot);
    return;
  }
  if (n <= VM_SCAN_SMALL_MAX) {  // one launch of one work-group, block after block
    launch_grouped(stage, "scan_small", VM_SCAN_WG, VM_SCAN_WG, counts, offsets, n, total, slot);
    return;
  }
  cl::Buffer sums = alloc(blocks * sizeof(uint32_t), "scan block sums");
  launch_grouped(stage, "scan_blocks", size_t(blocks) * VM_SCAN_WG, VM_SCAN_WG, counts, offsets, n,
                 sums, 0u);
  if (blocks <= VM_SCAN_FINISH_MAX) {
    launch_grouped(stage, "scan_finish", size_t(blocks) * VM_SCAN_WG, VM_SCAN_WG, offsets, n, sums,
                   blocks, total, slot);
    return;
  }
  cl::Buffer sum_offsets = alloc(blocks * sizeof(uint32_t), "scan block offsets");
  scan_level(stage, sums, sum_offsets, blocks, total, slot);
  launch(stage, "scan_add", n, offsets, n, sum_offsets);
}

void ClRuntime::scan_to(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n,
                        cl::Buffer& totals, uint32_t slot) {
  if (n == 0) {
    cl::Event ev;
    queue_.enqueueFillBuffer(totals, uint32_t(0), slot * sizeof(uint32_t), sizeof(uint32_t),
                             nullptr, &ev);
    launches_.push_back({stage, "fill", ev, sizeof(uint32_t)});
    return;
  }
  scan_level(stage, counts, offsets, n, totals, slot);
}

ClRuntime::GroupSums ClRuntime::group_sums(uint32_t n, const char* what) {
  GroupSums g;
  g.groups = static_cast<uint32_t>((uint64_t(n) + VM_SCAN_WG - 1) / VM_SCAN_WG);
  g.sums = alloc(std::max<size_t>(g.groups, 1) * sizeof(uint32_t), what);
  g.bases = alloc(std::max<size_t>(g.groups, 1) * sizeof(uint32_t), what);
  return g;
}

uint32_t ClRuntime::set_bases(GroupSums& g, const std::vector<uint32_t>& sums) {
  if (g.groups == 0) return 0;
  std::vector<uint32_t>& bases = pending_writes_.emplace_back(g.groups);
  std::exclusive_scan(sums.begin(), sums.begin() + g.groups, bases.begin(), 0u);
  queue_.enqueueWriteBuffer(g.bases, CL_FALSE, 0, bases.size() * sizeof(uint32_t), bases.data());
  write_bytes_ += bases.size() * sizeof(uint32_t);
  return bases.back() + sums[g.groups - 1];
}

uint32_t ClRuntime::group_total(Stage stage, GroupSums& g) {
  if (g.groups == 0) return 0;
  std::vector<uint32_t> sums(g.groups);
  read(stage, g.sums, 0, sums.size() * sizeof(uint32_t), sums.data());
  return set_bases(g, sums);
}

void ClRuntime::scan_offsets(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n) {
  if (n > 0) scan_level(stage, counts, offsets, n, scratch_total_, 0u);
}

uint32_t ClRuntime::scan(Stage stage, cl::Buffer& counts, cl::Buffer& offsets, uint32_t n) {
  if (n == 0) return 0;
  scan_level(stage, counts, offsets, n, scratch_total_, 0u);
  uint32_t total = 0;
  read(stage, scratch_total_, 0, sizeof total, &total);
  return total;
}

void ClRuntime::read(Stage stage, const cl::Buffer& b, size_t offset, size_t bytes, void* dst) {
  queue_.enqueueReadBuffer(b, CL_TRUE, offset, bytes, dst);
  async_pending_ = false;  // the queue is in order: every earlier read is done
  pending_writes_.clear();  // and every earlier write
  ++syncs_;
  ++stage_syncs_[size_t(stage)];
  stage_transfer_[size_t(stage)] += bytes;
}

void ClRuntime::read_async(Stage stage, const cl::Buffer& b, size_t offset, size_t bytes,
                           void* dst) {
  if (bytes == 0) return;
  queue_.enqueueReadBuffer(b, CL_FALSE, offset, bytes, dst);
  stage_transfer_[size_t(stage)] += bytes;
  async_pending_ = true;
}

void ClRuntime::complete_reads(Stage stage) {
  if (!async_pending_) return;
  queue_.finish();
  async_pending_ = false;
  pending_writes_.clear();
  ++syncs_;
  ++stage_syncs_[size_t(stage)];
}

void ClRuntime::copy(Stage stage, const cl::Buffer& src, cl::Buffer& dst, size_t bytes) {
  if (bytes == 0) return;
  cl::Event ev;
  queue_.enqueueCopyBuffer(src, dst, 0, 0, bytes, nullptr, &ev);
  launches_.push_back({stage, "copy", ev, 2 * uint64_t(bytes)});
}

void ClRuntime::reset_profile() {
  launches_.clear();
  kernel_profile_.clear();
  syncs_ = 0;
  write_bytes_ = 0;
  stage_syncs_.fill(0);
  stage_transfer_.fill(0);
}

ClRuntime::StageTimes ClRuntime::collect_profile() {
  queue_.finish();
  async_pending_ = false;
  pending_writes_.clear();
  StageTimes out{};
  for (Launch& l : launches_) {
    cl_ulong s = l.event.getProfilingInfo<CL_PROFILING_COMMAND_START>();
    cl_ulong e = l.event.getProfilingInfo<CL_PROFILING_COMMAND_END>();
    const double ms = (e - s) * 1e-6;
    StageTime& st = out[static_cast<size_t>(l.stage)];
    st.ms += ms;
    st.launches += 1;
    st.bytes += l.bytes;
    auto& k = kernel_profile_[std::string(stage_name(l.stage)) + "/" + l.name];
    k.first += ms;
    k.second += 1;
  }
  launches_.clear();
  for (size_t i = 0; i < kStageCount; ++i) {
    out[i].syncs = stage_syncs_[i];
    out[i].transfer_bytes = stage_transfer_[i];
  }
  stage_syncs_.fill(0);
  stage_transfer_.fill(0);
  return out;
}

}  // namespace vismap
