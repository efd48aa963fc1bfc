// Vulkan instance, device selection, validation capture and buffer helpers.
#pragma once
#include <atomic>
#include <cstddef>
#include <functional>
#include <map>
#include <mutex>
#include <tuple>
#include <cstdint>
#include <string>
#include <vector>

#include <vulkan/vulkan.hpp>

namespace basalt::vkx {

/// What --stats reports about the device.
struct DeviceInfo {
  std::string name;
  std::string driver;  // driver name and info, e.g. "llvmpipe: Mesa 22.3.6 (LLVM 15.0.6)"
  bool is_cpu = false;
  std::uint64_t max_storage_buffer_range = 0;
  std::uint64_t max_texel_buffer_elements = 0;
  std::uint32_t max_per_stage_sampled_images = 0;  // uniform texel views count here
};

/// A buffer with its memory, persistently mapped (host-visible memory).
struct Buffer {
  vk::Buffer buffer;
  vk::DeviceMemory memory;
  vk::DeviceSize size = 0;
  void* mapped = nullptr;
};

/// Owns the Vulkan instance, one compute queue of the chosen device, and validation capture.
class Context {
 public:
  /// \brief Opens a device.
  /// \param selector "auto" (a real GPU if present, else lavapipe), "lavapipe", or a
  ///        case-insensitive substring of a device name.
  /// \param validation enable VK_LAYER_KHRONOS_validation; its errors are counted and printed.
  /// \throws std::runtime_error when no device matches or Vulkan is unavailable.
  Context(const std::string& selector, bool validation);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  const DeviceInfo& info() const { return info_; }
  /// Number of validation-layer errors reported so far.
  std::size_t validation_errors() const { return validation_errors_.load(); }
  /// \brief True when BASALT_VALIDATION=1 is set in the environment.
  static bool validation_requested();
  /// \brief Names of every Vulkan device the loader reports.
  static std::vector<std::string> list_devices();

  /// \brief Creates a host-visible, mapped storage buffer of at least \p size bytes, zeroed
  ///        unless \p zeroed is false (then the caller zeroes it before a shader reads it).
  Buffer create_buffer(vk::DeviceSize size, vk::BufferUsageFlags usage, bool zeroed = true);
  /// \brief Releases a buffer created by create_buffer.
  void destroy_buffer(Buffer& buffer);
  /// \brief Records commands with \p record, submits them and waits for completion.
  template <class F>
  void submit_and_wait(F&& record) {
    vk::CommandBuffer cmd = begin_commands();
    record(cmd);
    end_commands_and_wait(cmd);
  }

  vk::Instance instance;
  vk::PhysicalDevice physical;
  vk::Device device;
  vk::Queue queue;
  std::uint32_t queue_family = 0;
  vk::CommandPool pool;

 private:
  friend class CompileDevice;  // memory_type
  vk::CommandBuffer begin_commands();
  void end_commands_and_wait(vk::CommandBuffer cmd);
  std::uint32_t memory_type(std::uint32_t bits) const;

  DeviceInfo info_;
  vk::DebugUtilsMessengerEXT messenger_;
  vk::Fence fence_;
  std::atomic<std::size_t> validation_errors_{0};
  friend VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                                      VkDebugUtilsMessageTypeFlagsEXT,
                                                      const VkDebugUtilsMessengerCallbackDataEXT*,
                                                      void*);
};

/// \brief A second logical device on a Context's physical device that only compiles pipelines.
/// lavapipe compiles a compute shader with LLVM at its first dispatch, on the thread of the
/// dispatching device's one queue, so one device compiles its pipelines one after another; a
/// second device's queue compiles on another core at the same time, and its code reaches the
/// first device through Mesa's shader cache, which both devices share (docs/performance.md).
class CompileDevice {
 public:
  /// \brief Opens the second device (the same queue family and features as \p ctx's).
  explicit CompileDevice(const Context& ctx);
  ~CompileDevice();
  CompileDevice(const CompileDevice&) = delete;
  CompileDevice& operator=(const CompileDevice&) = delete;
  /// \brief Whether Mesa's shader cache is on in this process's environment (without it the
  ///        second device's compile reaches nobody): MESA_SHADER_CACHE_DISABLE and the older
  ///        MESA_GLSL_CACHE_DISABLE unset or false.
  static bool shader_cache_on();
  /// A uniform texel buffer binding's view format, its buffer's size and the view's range.
  struct TexelBinding {
    vk::Format format;
    vk::DeviceSize buffer_bytes, view_bytes;
  };
  /// \brief Creates the compute pipeline of SPIR-V \p code (\p bytes long) with \p spec,
  ///        descriptor set layout \p bindings and \p push.size() bytes of push constants;
  ///        binds each storage buffer to a small buffer and the k-th uniform texel buffer to a
  ///        buffer and view as \p texels[k] describes (no memory is touched); dispatches no
  ///        workgroup with push constants \p push (lavapipe compiles the shader all the same);
  ///        calls \p meanwhile while this device's queue compiles (with a function that tells
  ///        whether the compile has ended), then waits and destroys the pipeline. Calls from
  ///        several threads take turns.
  void compile(const std::uint32_t* code, std::size_t bytes, const vk::SpecializationInfo& spec,
               const std::vector<vk::DescriptorSetLayoutBinding>& bindings,
               const std::vector<TexelBinding>& texels, const std::vector<std::uint8_t>& push,
               const std::function<void(const std::function<bool()>&)>& meanwhile = {});

 private:
  void release_texel_buffers();
  vk::Device device_;
  vk::Queue queue_;
  vk::CommandPool pool_;
  vk::Fence fence_;
  std::uint32_t memory_type_ = 0;
  Buffer dummy_;  // 4096 bytes, bound to every storage buffer binding
  // The texel views' buffers, by format, size and range, bound to backing_ (which is at least
  // backing_bytes_ long), and their views.
  std::map<std::tuple<VkFormat, vk::DeviceSize, vk::DeviceSize>, std::pair<vk::Buffer, vk::BufferView>>
      texel_buffers_;
  vk::DeviceMemory backing_;
  vk::DeviceSize backing_bytes_ = 0;
  std::mutex mutex_;
};

}  // namespace basalt::vkx
