// Vulkan instance, device selection, validation capture and buffer helpers.
#include "vk/context.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <exception>
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

/// A device of \p physical with one queue of \p family and the features basalt uses
/// (shaderInt64).
vk::Device create_device(vk::PhysicalDevice physical, std::uint32_t family) {
  float priority = 1.0f;
  vk::DeviceQueueCreateInfo queue_info{
      .queueFamilyIndex = family, .queueCount = 1, .pQueuePriorities = &priority};
  vk::PhysicalDeviceFeatures features{};
  features.shaderInt64 = VK_TRUE;
  return physical.createDevice(
      {.queueCreateInfoCount = 1, .pQueueCreateInfos = &queue_info, .pEnabledFeatures = &features});
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
  // 64-bit integers: the sample indices of the halton and zsobol samplers
  // (docs/sampler-spec.md 4); every desktop driver and lavapipe have them.
  if (!physical.getFeatures().shaderInt64)
    throw std::runtime_error(info_.name + " lacks shaderInt64, which basalt's samplers need");
  device = create_device(physical, queue_family);
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

Buffer Context::create_buffer(vk::DeviceSize size, vk::BufferUsageFlags usage, bool zeroed) {
  Buffer b;
  b.size = std::max<vk::DeviceSize>(size, 16);
  b.buffer = device.createBuffer({.size = b.size, .usage = usage});
  auto req = device.getBufferMemoryRequirements(b.buffer);
  b.memory = device.allocateMemory(
      {.allocationSize = req.size, .memoryTypeIndex = memory_type(req.memoryTypeBits)});
  device.bindBufferMemory(b.buffer, b.memory, 0);
  b.mapped = device.mapMemory(b.memory, 0, VK_WHOLE_SIZE);
  if (zeroed) std::memset(b.mapped, 0, b.size);
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

namespace {
constexpr vk::BufferUsageFlags kDummyUsage =
    vk::BufferUsageFlagBits::eStorageBuffer | vk::BufferUsageFlagBits::eUniformTexelBuffer;
}  // namespace

CompileDevice::CompileDevice(const Context& ctx) {
  // Its calls go through the default dispatcher's entry points, which the Context loaded for
  // its own device of the same driver (re-initialising it here would race the other threads).
  device_ = create_device(ctx.physical, ctx.queue_family);
  queue_ = device_.getQueue(ctx.queue_family, 0);
  pool_ = device_.createCommandPool({.queueFamilyIndex = ctx.queue_family});
  fence_ = device_.createFence({});
  dummy_.size = 4096;
  dummy_.buffer = device_.createBuffer({.size = dummy_.size, .usage = kDummyUsage});
  const auto req = device_.getBufferMemoryRequirements(dummy_.buffer);
  memory_type_ = ctx.memory_type(req.memoryTypeBits);
  dummy_.memory = device_.allocateMemory({.allocationSize = req.size, .memoryTypeIndex = memory_type_});
  device_.bindBufferMemory(dummy_.buffer, dummy_.memory, 0);
}

CompileDevice::~CompileDevice() {
  device_.waitIdle();
  release_texel_buffers();
  device_.destroyBuffer(dummy_.buffer);
  device_.freeMemory(dummy_.memory);
  device_.destroyFence(fence_);
  device_.destroyCommandPool(pool_);
  device_.destroy();
}

bool CompileDevice::shader_cache_on() {
  for (const char* name : {"MESA_SHADER_CACHE_DISABLE", "MESA_GLSL_CACHE_DISABLE"}) {
    const char* v = std::getenv(name);
    if (v && *v && lower(v) != "false" && std::string(v) != "0") return false;
  }
  return true;
}

void CompileDevice::release_texel_buffers() {
  for (auto& [key, made] : texel_buffers_) {
    device_.destroyBufferView(made.second);
    device_.destroyBuffer(made.first);
  }
  texel_buffers_.clear();
  if (backing_) device_.freeMemory(backing_);
  backing_ = nullptr;
  backing_bytes_ = 0;
}

void CompileDevice::compile(const std::uint32_t* code, std::size_t bytes,
                            const vk::SpecializationInfo& spec,
                            const std::vector<vk::DescriptorSetLayoutBinding>& bindings,
                            const std::vector<TexelBinding>& texels,
                            const std::vector<std::uint8_t>& push,
                            const std::function<void(const std::function<bool()>&)>& meanwhile) {
  const std::uint32_t push_bytes = std::uint32_t(push.size());
  const std::lock_guard<std::mutex> lock(mutex_);
  const vk::DescriptorSetLayout set_layout = device_.createDescriptorSetLayout(
      {.bindingCount = std::uint32_t(bindings.size()), .pBindings = bindings.data()});
  const vk::PushConstantRange range{
      .stageFlags = vk::ShaderStageFlagBits::eCompute, .offset = 0, .size = push_bytes};
  const vk::PipelineLayout layout = device_.createPipelineLayout({.setLayoutCount = 1,
                                                                  .pSetLayouts = &set_layout,
                                                                  .pushConstantRangeCount = 1,
                                                                  .pPushConstantRanges = &range});
  const vk::ShaderModule module = device_.createShaderModule({.codeSize = bytes, .pCode = code});
  auto made = device_.createComputePipeline(
      nullptr, {.stage = {.stage = vk::ShaderStageFlagBits::eCompute,
                          .module = module,
                          .pName = "main",
                          .pSpecializationInfo = &spec},
                .layout = layout});
  device_.destroyShaderModule(module);
  const std::uint32_t texel_count = std::uint32_t(texels.size());
  const vk::DescriptorPoolSize sizes[2] = {
      {.type = vk::DescriptorType::eStorageBuffer,
       .descriptorCount = std::max(1u, std::uint32_t(bindings.size()) - texel_count)},
      {.type = vk::DescriptorType::eUniformTexelBuffer,
       .descriptorCount = std::max(1u, texel_count)}};
  const vk::DescriptorPool pool =
      device_.createDescriptorPool({.maxSets = 1, .poolSizeCount = 2, .pPoolSizes = sizes});
  const vk::DescriptorSet set = device_.allocateDescriptorSets(
      {.descriptorPool = pool, .descriptorSetCount = 1, .pSetLayouts = &set_layout})[0];
  // Every storage buffer binding gets the small buffer: nothing runs, but a dispatch needs its
  // descriptors valid. A texel view gets one of its table's size and range, all aliasing one
  // allocation that nothing touches: lavapipe's compiled code depends on them (they are part
  // of Mesa's cache key), storage buffers' sizes are not.
  const vk::DescriptorBufferInfo whole{.buffer = dummy_.buffer, .offset = 0, .range = dummy_.size};
  vk::DeviceSize largest = 0;
  for (const TexelBinding& t : texels) largest = std::max(largest, t.buffer_bytes);
  if (largest > backing_bytes_) {
    release_texel_buffers();
    vk::Buffer probe = device_.createBuffer({.size = largest, .usage = kDummyUsage});
    const vk::DeviceSize bytes = device_.getBufferMemoryRequirements(probe).size;
    device_.destroyBuffer(probe);
    backing_ = device_.allocateMemory({.allocationSize = bytes, .memoryTypeIndex = memory_type_});
    backing_bytes_ = largest;
  }
  std::vector<vk::BufferView> texel_views;
  for (const TexelBinding& t : texels) {
    auto& [buffer, view] = texel_buffers_[{VkFormat(t.format), t.buffer_bytes, t.view_bytes}];
    if (!view) {
      buffer = device_.createBuffer({.size = t.buffer_bytes, .usage = kDummyUsage});
      (void)device_.getBufferMemoryRequirements(buffer);
      device_.bindBufferMemory(buffer, backing_, 0);
      view = device_.createBufferView(
          {.buffer = buffer, .format = t.format, .offset = 0, .range = t.view_bytes});
    }
    texel_views.push_back(view);
  }
  std::vector<vk::WriteDescriptorSet> writes;
  std::uint32_t k = 0;
  for (const vk::DescriptorSetLayoutBinding& b : bindings) {
    vk::WriteDescriptorSet w{.dstSet = set,
                             .dstBinding = b.binding,
                             .descriptorCount = 1,
                             .descriptorType = b.descriptorType};
    if (b.descriptorType == vk::DescriptorType::eUniformTexelBuffer)
      w.pTexelBufferView = &texel_views.at(k++);
    else
      w.pBufferInfo = &whole;
    writes.push_back(w);
  }
  device_.updateDescriptorSets(writes, {});
  vk::CommandBuffer cmd = device_.allocateCommandBuffers(
      {.commandPool = pool_, .level = vk::CommandBufferLevel::ePrimary, .commandBufferCount = 1})[0];
  cmd.begin({.flags = vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
  if (made.result == vk::Result::eSuccess) {
    cmd.bindPipeline(vk::PipelineBindPoint::eCompute, made.value);
    cmd.bindDescriptorSets(vk::PipelineBindPoint::eCompute, layout, 0, set, {});
    cmd.pushConstants(layout, vk::ShaderStageFlagBits::eCompute, 0, push_bytes, push.data());
    cmd.dispatch(0, 1, 1);  // no workgroup: lavapipe compiles the shader all the same
  }
  cmd.end();
  queue_.submit(vk::SubmitInfo{.commandBufferCount = 1, .pCommandBuffers = &cmd}, fence_);
  // This device's queue thread compiles while the caller's work runs here.
  std::exception_ptr error;
  if (meanwhile) try {
      meanwhile([this] { return device_.getFenceStatus(fence_) == vk::Result::eSuccess; });
    } catch (...) {
      error = std::current_exception();
    }
  const vk::Result waited = device_.waitForFences(fence_, VK_TRUE, UINT64_MAX);
  device_.resetFences(fence_);
  device_.freeCommandBuffers(pool_, cmd);
  device_.destroyDescriptorPool(pool);
  if (made.result == vk::Result::eSuccess) device_.destroyPipeline(made.value);
  device_.destroyPipelineLayout(layout);
  device_.destroyDescriptorSetLayout(set_layout);
  if (error) std::rethrow_exception(error);
  if (waited != vk::Result::eSuccess) throw std::runtime_error("Vulkan fence wait failed");
}

}  // namespace basalt::vkx
