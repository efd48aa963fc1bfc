// Vulkan instance, device selection, validation capture and buffer helpers.
#pragma once
#include <atomic>
#include <cstddef>
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

  /// \brief Creates a host-visible, mapped storage buffer of at least \p size bytes.
  Buffer create_buffer(vk::DeviceSize size, vk::BufferUsageFlags usage);
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

}  // namespace basalt::vkx
