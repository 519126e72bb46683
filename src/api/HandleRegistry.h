// HandleRegistry.h: the table behind the C ABI's opaque handles.
//
// A handle is not a pointer but a 64-bit name for a registry slot:
//
//   bits  0-23  slot index + 1      bits 48-55  the object's NimbusHandleType
//   bits 24-47  slot generation     bits 56-63  magic 0x4E ('N')
//
// Looking one up checks the magic, the slot, the generation (bumped whenever a slot is freed)
// and the type, so a released handle, a handle of another type or a random integer is an
// ApiError, never a dangling pointer. Freed slots are reused oldest first and only once many
// are free, so a stale handle stays detectable for a long time (a slot's generation would have
// to wrap 2^24 times to alias).
//
// The registry counts the caller's references per handle; objects themselves are shared_ptrs,
// so a scene can keep a light alive after the caller released the light's handle. The
// registry is never destroyed: objects still alive at exit (a session still rendering) are not
// torn down while static destructors of TBB or OpenVDB run.
#pragma once

#include "nimbus.h"

#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <vector>

namespace nimbus::api {

const char* handleTypeName(NimbusHandleType type);

class ApiObject {
public:
    explicit ApiObject(NimbusHandleType type) : mType(type) {}
    virtual ~ApiObject() = default;
    NimbusHandleType type() const { return mType; }

    // Called (without the registry lock) when the caller's last reference is given back,
    // before the registry drops its shared_ptr: sessions cancel their render here.
    virtual void onLastRelease() {}

private:
    friend class HandleRegistry;
    NimbusHandleType mType;
    NimbusHandle mHandle = 0;  // the live handle naming this object, 0 if none (registry lock)
};

class HandleRegistry {
public:
    static HandleRegistry& instance();

    // A new handle with one reference.
    NimbusHandle add(std::shared_ptr<ApiObject> object);
    // A reference to the object's live handle, or a new handle if it has none.
    NimbusHandle handleFor(const std::shared_ptr<ApiObject>& object);

    std::shared_ptr<ApiObject> get(NimbusHandle handle) const;  // any type
    template <class T>
    std::shared_ptr<T> get(NimbusHandle handle, NimbusHandleType type) const
    {
        return std::static_pointer_cast<T>(getTyped(handle, type));
    }

    void retain(NimbusHandle handle);
    void release(NimbusHandle handle);

private:
    struct Slot {
        uint32_t generation = 1;
        uint32_t references = 0;
        std::shared_ptr<ApiObject> object;  // null: free
    };

    std::shared_ptr<ApiObject> getTyped(NimbusHandle handle, NimbusHandleType type) const;
    Slot& slotOf(NimbusHandle handle) const;  // under mMutex; throws for a bad handle
    NimbusHandle addLocked(std::shared_ptr<ApiObject> object);

    mutable std::mutex mMutex;
    mutable std::vector<Slot> mSlots;
    std::deque<uint32_t> mFree;
};

}  // namespace nimbus::api
