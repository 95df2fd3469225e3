// Kernel launches in the CUDA emulation.  The build rewrites
//   kernel<<<grid, block, shared_bytes, stream>>>(args...);
// into
//   ::overlap::cuda_emulation::launchKernel(kernel, "kernel", grid, block,
//                                           shared_bytes, stream)(args...);
// on the same source line (gpu/emulation/rewrite_launches.py), so the call
// site that the checks name is the .cu line of the launch.
//
// A launch is checked as a GPU checks it (block and grid limits, shared
// memory: cudaErrorInvalidConfiguration through cudaGetLastError, nothing
// enqueued) and each pointer argument must point into a live device or pinned
// allocation.  The arguments are copied, as CUDA copies them, and the kernel
// runs when its stream is waited for.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <source_location>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace overlap::cuda_emulation {
namespace detail {

struct KernelLaunch {
  const char* kernel_name;
  std::source_location site;
  dim3 grid;
  dim3 block;
  std::size_t shared_bytes;
  cudaStream_t stream;
  std::function<void()> run_thread;            // the kernel body, for the running fiber's thread
  std::vector<const void*> pointer_arguments;  // by argument position; null if not a pointer
};

// Validates the launch (setting the thread's last error) and enqueues it.
void enqueueLaunch(KernelLaunch launch);

template <class T>
const void* pointerArgument(const T& argument) {
  if constexpr (std::is_pointer_v<T> && !std::is_function_v<std::remove_pointer_t<T>>) {
    return argument;
  } else {
    return nullptr;
  }
}

}  // namespace detail

template <class... Params>
class KernelLauncher {
 public:
  KernelLauncher(void (*kernel)(Params...), detail::KernelLaunch launch)
      : kernel_(kernel), launch_(std::move(launch)) {}

  template <class... Args>
  void operator()(Args&&... args) && {
    static_assert(sizeof...(Args) == sizeof...(Params), "wrong number of kernel arguments");
    auto arguments =
        std::make_shared<const std::tuple<std::decay_t<Params>...>>(std::forward<Args>(args)...);
    launch_.pointer_arguments = std::apply(
        [](const auto&... values) {
          return std::vector<const void*>{detail::pointerArgument(values)...};
        },
        *arguments);
    launch_.run_thread = [kernel = kernel_, arguments] { std::apply(kernel, *arguments); };
    detail::enqueueLaunch(std::move(launch_));
  }

 private:
  void (*kernel_)(Params...);
  detail::KernelLaunch launch_;
};

template <class... Params>
KernelLauncher<Params...> launchKernel(
    void (*kernel)(Params...), const char* name, dim3 grid, dim3 block,
    std::size_t shared_bytes = 0, cudaStream_t stream = nullptr,
    std::source_location site = std::source_location::current()) {
  return KernelLauncher<Params...>(
      kernel, detail::KernelLaunch{name, site, grid, block, shared_bytes, stream, {}, {}});
}

}  // namespace overlap::cuda_emulation
