#include "HandleRegistry.h"

#include "ApiError.h"

#include <cstdio>

namespace nimbus::api {

namespace {

constexpr uint64_t kMagic = 0x4E;
constexpr uint64_t kIndexBits = 24, kGenerationBits = 24;
constexpr uint64_t kIndexMask = (uint64_t(1) << kIndexBits) - 1;
constexpr uint64_t kGenerationMask = (uint64_t(1) << kGenerationBits) - 1;
// Freed slots wait in line until this many are free, so stale handles stay detectable.
constexpr size_t kReuseAfter = 1024;

NimbusHandle encode(uint32_t index, uint32_t generation, NimbusHandleType type)
{
    return (kMagic << 56) | (uint64_t(type) << 48) | ((uint64_t(generation) & kGenerationMask) << kIndexBits) |
           (uint64_t(index) + 1);
}

std::string hex(NimbusHandle h)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "0x%016llx", static_cast<unsigned long long>(h));
    return buf;
}

}  // namespace

const char* handleTypeName(NimbusHandleType type)
{
    switch (type) {
    case NIMBUS_TYPE_SCENE: return "scene";
    case NIMBUS_TYPE_CAMERA: return "camera";
    case NIMBUS_TYPE_LIGHT: return "light";
    case NIMBUS_TYPE_VOLUME: return "volume";
    case NIMBUS_TYPE_SESSION: return "session";
    case NIMBUS_TYPE_FRAME: return "frame";
    }
    return "unknown";
}

HandleRegistry& HandleRegistry::instance()
{
    static HandleRegistry* registry = new HandleRegistry();  // never destroyed: see the header
    return *registry;
}

NimbusHandle HandleRegistry::addLocked(std::shared_ptr<ApiObject> object)
{
    uint32_t index;
    if (mFree.size() > kReuseAfter) {
        index = mFree.front();
        mFree.pop_front();
    } else {
        if (mSlots.size() >= kIndexMask)
            throw ApiError(NIMBUS_ERROR_OUT_OF_MEMORY, "too many live nimbus objects (16M handles)");
        index = uint32_t(mSlots.size());
        mSlots.emplace_back();
    }
    Slot& slot = mSlots[index];
    slot.references = 1;
    slot.object = std::move(object);
    NimbusHandle h = encode(index, slot.generation, slot.object->type());
    slot.object->mHandle = h;
    return h;
}

NimbusHandle HandleRegistry::add(std::shared_ptr<ApiObject> object)
{
    std::lock_guard<std::mutex> lock(mMutex);
    return addLocked(std::move(object));
}

NimbusHandle HandleRegistry::handleFor(const std::shared_ptr<ApiObject>& object)
{
    std::lock_guard<std::mutex> lock(mMutex);
    if (object->mHandle != 0) {
        ++slotOf(object->mHandle).references;
        return object->mHandle;
    }
    return addLocked(object);
}

HandleRegistry::Slot& HandleRegistry::slotOf(NimbusHandle h) const
{
    if (h == NIMBUS_NULL_HANDLE)
        throw ApiError(NIMBUS_ERROR_INVALID_HANDLE, "null handle");
    const uint64_t index = (h & kIndexMask);
    if ((h >> 56) != kMagic || index == 0 || index > mSlots.size())
        throw ApiError(NIMBUS_ERROR_INVALID_HANDLE, "invalid handle " + hex(h) + ": not a nimbus handle");
    Slot& slot = mSlots[index - 1];
    const uint32_t generation = uint32_t((h >> kIndexBits) & kGenerationMask);
    const auto type = NimbusHandleType((h >> 48) & 0xFF);
    if (!slot.object || (slot.generation & kGenerationMask) != generation || slot.object->type() != type)
        throw ApiError(NIMBUS_ERROR_INVALID_HANDLE, std::string("invalid handle ") + hex(h) + ": the " +
                                                        handleTypeName(type) + " it named was released");
    return slot;
}

std::shared_ptr<ApiObject> HandleRegistry::get(NimbusHandle h) const
{
    std::lock_guard<std::mutex> lock(mMutex);
    return slotOf(h).object;
}

std::shared_ptr<ApiObject> HandleRegistry::getTyped(NimbusHandle h, NimbusHandleType type) const
{
    std::lock_guard<std::mutex> lock(mMutex);
    const Slot& slot = slotOf(h);
    if (slot.object->type() != type)
        throw ApiError(NIMBUS_ERROR_WRONG_HANDLE_TYPE, std::string("wrong handle type: expected a ") +
                                                           handleTypeName(type) + ", got a " +
                                                           handleTypeName(slot.object->type()));
    return slot.object;
}

void HandleRegistry::retain(NimbusHandle h)
{
    std::lock_guard<std::mutex> lock(mMutex);
    Slot& slot = slotOf(h);
    if (slot.references == UINT32_MAX)
        throw ApiError(NIMBUS_ERROR_INVALID_ARGUMENT, "reference count overflow");
    ++slot.references;
}

void HandleRegistry::release(NimbusHandle h)
{
    std::shared_ptr<ApiObject> last;
    {
        std::lock_guard<std::mutex> lock(mMutex);
        Slot& slot = slotOf(h);
        if (slot.references > 1) {
            --slot.references;
            return;
        }
        last = slot.object;
    }
    // The last reference: let the object stop what it runs (a session's render) without the
    // lock held, since that may take a tile's time and may call back into the API. It may refuse
    // (throw), and then nothing changes.
    last->onLastRelease();
    std::shared_ptr<ApiObject> dropped;
    {
        std::lock_guard<std::mutex> lock(mMutex);
        Slot& slot = slotOf(h);
        if (slot.references > 1) {  // retained meanwhile by another thread
            --slot.references;
            return;
        }
        dropped = std::move(slot.object);
        slot.object.reset();
        slot.references = 0;
        slot.generation = (slot.generation + 1) & kGenerationMask;
        if (slot.generation == 0)
            slot.generation = 1;
        dropped->mHandle = 0;
        mFree.push_back(uint32_t((h & kIndexMask) - 1));
    }
    // `dropped` (and `last`) destroy the object here, outside the lock, if nothing else holds it.
}

}  // namespace nimbus::api
