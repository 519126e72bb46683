// ApiSession.h: render sessions and frames behind C ABI handles.
//
// A session renders its scene's committed snapshot, on the caller's thread (render) or on a
// thread of its own (start / wait), one render at a time. Cancel is an atomic flag the
// renderer reads between tiles, so it takes effect within one tile's time once the march has
// started (loading volumes and building shadow maps are not interrupted). The user's progress
// callback is called under a mutex, so it never runs twice at once, with a fraction that never
// decreases. A finished render becomes a frame: an immutable RenderResult shared by the frame
// handles, so AOV pointers stay valid after the session renders again or is released.
#pragma once

#include "ApiObjects.h"

#include "../engine/Renderer.h"

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace nimbus::api {

class FrameObject : public ApiObject {
public:
    FrameObject(std::shared_ptr<const Scene> scene, std::shared_ptr<const RenderResult> result)
        : ApiObject(NIMBUS_TYPE_FRAME), mScene(std::move(scene)), mResult(std::move(result))
    {
    }
    const Scene& scene() const { return *mScene; }
    const RenderResult& result() const { return *mResult; }

private:
    std::shared_ptr<const Scene> mScene;
    std::shared_ptr<const RenderResult> mResult;
};

class SessionObject : public ApiObject {
public:
    explicit SessionObject(std::shared_ptr<SceneObject> scene)
        : ApiObject(NIMBUS_TYPE_SESSION), mScene(std::move(scene))
    {
    }
    ~SessionObject() override;

    void setProgressCallback(NimbusProgressCallback callback, void* userData);
    NimbusStatus render(std::string& message);  // synchronous; the render's status
    void start();
    NimbusStatus wait(double timeoutSeconds, std::string& message);
    void cancel() { mCancel = true; }
    NimbusSessionState state(float* progress) const;
    std::shared_ptr<FrameObject> frame() const;

    // Refuses (BUSY) from the session's own progress callback; otherwise cancels and joins.
    void onLastRelease() override;

private:
    std::shared_ptr<const Scene> begin();  // idle/finished -> running, or BUSY
    void run(std::shared_ptr<const Scene> scene);
    bool progress(float fraction);

    std::shared_ptr<SceneObject> mScene;

    mutable std::mutex mMutex;
    std::condition_variable mDone;
    NimbusSessionState mState = NIMBUS_SESSION_IDLE;
    NimbusStatus mStatus = NIMBUS_OK;
    std::string mMessage;
    std::shared_ptr<FrameObject> mFrame;
    std::thread mThread;

    std::mutex mCallbackMutex;
    NimbusProgressCallback mCallback = nullptr;
    void* mUserData = nullptr;
    float mProgressReported = 0.0f;  // under mCallbackMutex

    std::atomic<bool> mCancel{false};
    std::atomic<float> mProgress{0.0f};
};

}  // namespace nimbus::api
