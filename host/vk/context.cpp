// Vulkan instance, device selection, validation capture and buffer helpers.
#include "vk/context.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <stdexcept>

VULKAN_HPP_DEFAULT_DISPATCH_LOADER_DYNAMIC_STORAGE

namespace basalt::vkx {

namespace {

const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

/// Lower-case copy, for case-insensitive device-name matching.
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

/// Loads the global Vulkan entry points once per process.
void init_loader() {
  static vk::DynamicLoader loader;
  static bool done = false;
  if (done) return;
  auto get_instance_proc =
      loader.getProcAddress<PFN_vkGetInstanceProcAddr>("vkGetInstanceProcAddr");
  if (!get_instance_proc) throw std::runtime_error("Vulkan loader (libvulkan.so.1) not found");
  VULKAN_HPP_DEFAULT_DISPATCHER.init(get_instance_proc);
  done = true;
}

/// Creates a bare instance, for listing devices.
vk::Instance create_instance(bool validation) {
  init_loader();
  vk::ApplicationInfo app{.pApplicationName = "basalt",
                          .applicationVersion = 1,
                          .pEngineName = "basalt",
                          .engineVersion = 1,
                          .apiVersion = VK_API_VERSION_1_1};
  std::vector<const char*> layers, extensions;
  if (validation) {
    auto available = vk::enumerateInstanceLayerProperties();
    bool found = std::any_of(available.begin(), available.end(), [](const auto& l) {
      return std::strcmp(l.layerName, kValidationLayer) == 0;
    });
    if (!found)
      throw std::runtime_error(
          "BASALT_VALIDATION=1 but VK_LAYER_KHRONOS_validation is not installed "
          "(apt-get install vulkan-validationlayers)");
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  vk::InstanceCreateInfo info{.pApplicationInfo = &app,
                              .enabledLayerCount = uint32_t(layers.size()),
                              .ppEnabledLayerNames = layers.data(),
                              .enabledExtensionCount = uint32_t(extensions.size()),
                              .ppEnabledExtensionNames = extensions.data()};
  vk::Instance instance = vk::createInstance(info);
  VULKAN_HPP_DEFAULT_DISPATCHER.init(instance);
  return instance;
}

/// Preference order for "auto": real GPUs first, lavapipe last.
int device_rank(const vk::PhysicalDeviceProperties& p) {
  switch (p.deviceType) {
    case vk::PhysicalDeviceType::eDiscreteGpu: return 0;
    case vk::PhysicalDeviceType::eIntegratedGpu: return 1;
    case vk::PhysicalDeviceType::eVirtualGpu: return 2;
    case vk::PhysicalDeviceType::eCpu: return 4;
    default: return 3;
  }
}

}  // namespace

/// Counts and prints validation-layer errors (and prints warnings).
VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data,
                                             void* user) {
  auto* ctx = static_cast<Context*>(user);
  if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    ctx->validation_errors_++;
    std::cerr << "basalt: Vulkan validation error: " << data->pMessage << "\n";
  } else if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    std::cerr << "basalt: Vulkan validation warning: " << data->pMessage << "\n";
  }
  return VK_FALSE;
}

bool Context::validation_requested() {
  const char* v = std::getenv("BASALT_VALIDATION");
  return v && std::string(v) == "1";
}

std::vector<std::string> Context::list_devices() {
  vk::Instance instance = create_instance(false);
  std::vector<std::string> names;
  for (auto& d : instance.enumeratePhysicalDevices())
    names.push_back(d.getProperties().deviceName.data());
  instance.destroy();
  return names;
}

Context::Context(const std::string& selector, bool validation) {
  instance = create_instance(validation);
  if (validation) {
    using S = vk::DebugUtilsMessageSeverityFlagBitsEXT;
    using T = vk::DebugUtilsMessageTypeFlagBitsEXT;
    messenger_ = instance.createDebugUtilsMessengerEXT(
        {.messageSeverity = S::eWarning | S::eError,
         .messageType = T::eGeneral | T::eValidation | T::ePerformance,
         .pfnUserCallback = debug_callback,
         .pUserData = this});
  }
  auto devices = instance.enumeratePhysicalDevices();
  std::vector<vk::PhysicalDevice> candidates;
  for (auto& d : devices) {
    auto props = d.getProperties();
    std::string name = lower(props.deviceName.data());
    bool is_lavapipe = props.deviceType == vk::PhysicalDeviceType::eCpu ||
                       name.find("llvmpipe") != std::string::npos;
    if (selector == "auto" || (selector == "lavapipe" && is_lavapipe) ||
        (selector != "lavapipe" && name.find(lower(selector)) != std::string::npos))
      candidates.push_back(d);
  }
  if (candidates.empty()) {
    std::string msg = "no Vulkan device matches '" + selector + "'; devices:";
    for (auto& d : devices) msg += std::string(" '") + d.getProperties().deviceName.data() + "'";
    if (devices.empty()) msg += " none (apt-get install mesa-vulkan-drivers for lavapipe)";
    throw std::runtime_error(msg);
  }
  std::stable_sort(candidates.begin(), candidates.end(), [](auto& a, auto& b) {
    return device_rank(a.getProperties()) < device_rank(b.getProperties());
  });
  physical = candidates.front();

  auto props2 = physical.getProperties2<vk::PhysicalDeviceProperties2,
                                         vk::PhysicalDeviceDriverProperties>();
  const auto& props = props2.get<vk::PhysicalDeviceProperties2>().properties;
  const auto& driver = props2.get<vk::PhysicalDeviceDriverProperties>();
  info_.name = props.deviceName.data();
  info_.driver = std::string(driver.driverName.data()) + ": " + driver.driverInfo.data();
  info_.is_cpu = props.deviceType == vk::PhysicalDeviceType::eCpu;
  info_.max_storage_buffer_range = props.limits.maxStorageBufferRange;
  info_.max_texel_buffer_elements = props.limits.maxTexelBufferElements;
  info_.max_per_stage_sampled_images = props.limits.maxPerStageDescriptorSampledImages;

  auto families = physical.getQueueFamilyProperties();
  queue_family = UINT32_MAX;
  for (std::uint32_t i = 0; i < families.size(); ++i)
    if (families[i].queueFlags & vk::QueueFlagBits::eCompute) {
      queue_family = i;
      break;
    }
  if (queue_family == UINT32_MAX) throw std::runtime_error(info_.name + " has no compute queue");
  float priority = 1.0f;
  vk::DeviceQueueCreateInfo queue_info{
      .queueFamilyIndex = queue_family, .queueCount = 1, .pQueuePriorities = &priority};
  // 64-bit integers: the sample indices of the halton and zsobol samplers
  // (docs/sampler-spec.md 4); every desktop driver and lavapipe have them.
  if (!physical.getFeatures().shaderInt64)
    throw std::runtime_error(info_.name + " lacks shaderInt64, which basalt's samplers need");
  vk::PhysicalDeviceFeatures features{};
  features.shaderInt64 = VK_TRUE;
  device = physical.createDevice({.queueCreateInfoCount = 1,
                                  .pQueueCreateInfos = &queue_info,
                                  .pEnabledFeatures = &features});
  VULKAN_HPP_DEFAULT_DISPATCHER.init(device);
  queue = device.getQueue(queue_family, 0);
  pool = device.createCommandPool({.flags = vk::CommandPoolCreateFlagBits::eResetCommandBuffer,
                                   .queueFamilyIndex = queue_family});
  fence_ = device.createFence({});
}

Context::~Context() {
  if (device) {
    device.waitIdle();
    device.destroyFence(fence_);
    device.destroyCommandPool(pool);
    device.destroy();
  }
  if (messenger_) instance.destroyDebugUtilsMessengerEXT(messenger_);
  if (instance) instance.destroy();
}

std::uint32_t Context::memory_type(std::uint32_t bits) const {
  auto mem = physical.getMemoryProperties();
  using M = vk::MemoryPropertyFlagBits;
  // Prefer memory that is both device-local and mappable (lavapipe, unified memory, ReBAR).
  const vk::MemoryPropertyFlags wanted[] = {
      M::eDeviceLocal | M::eHostVisible | M::eHostCoherent, M::eHostVisible | M::eHostCoherent};
  for (auto flags : wanted)
    for (std::uint32_t i = 0; i < mem.memoryTypeCount; ++i)
      if ((bits & (1u << i)) && (mem.memoryTypes[i].propertyFlags & flags) == flags) return i;
  throw std::runtime_error("no host-visible coherent memory type");
}

Buffer Context::create_buffer(vk::DeviceSize size, vk::BufferUsageFlags usage) {
  Buffer b;
  b.size = std::max<vk::DeviceSize>(size, 16);
  b.buffer = device.createBuffer({.size = b.size, .usage = usage});
  auto req = device.getBufferMemoryRequirements(b.buffer);
  b.memory = device.allocateMemory(
      {.allocationSize = req.size, .memoryTypeIndex = memory_type(req.memoryTypeBits)});
  device.bindBufferMemory(b.buffer, b.memory, 0);
  b.mapped = device.mapMemory(b.memory, 0, VK_WHOLE_SIZE);
  std::memset(b.mapped, 0, b.size);
  return b;
}

void Context::destroy_buffer(Buffer& b) {
  if (!b.buffer) return;
  device.unmapMemory(b.memory);
  device.destroyBuffer(b.buffer);
  device.freeMemory(b.memory);
  b = Buffer{};
}

vk::CommandBuffer Context::begin_commands() {
  vk::CommandBuffer cmd = device.allocateCommandBuffers(
      {.commandPool = pool, .level = vk::CommandBufferLevel::ePrimary, .commandBufferCount = 1})[0];
  cmd.begin({.flags = vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
  return cmd;
}

void Context::end_commands_and_wait(vk::CommandBuffer cmd) {
  cmd.end();
  queue.submit(vk::SubmitInfo{.commandBufferCount = 1, .pCommandBuffers = &cmd}, fence_);
  auto result = device.waitForFences(fence_, VK_TRUE, UINT64_MAX);
  if (result != vk::Result::eSuccess) throw std::runtime_error("Vulkan fence wait failed");
  device.resetFences(fence_);
  device.freeCommandBuffers(pool, cmd);
}

}  // namespace basalt::vkx
