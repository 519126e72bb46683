#include "ApiSession.h"

#include "ApiError.h"

#include "../core/Error.h"
#include "../core/OneLine.h"

#include <chrono>

namespace nimbus::api {

namespace {

// The session whose progress callback the current thread is running, if any.
thread_local const SessionObject* tInCallback = nullptr;

}  // namespace

SessionObject::~SessionObject()
{
    mCancel = true;
    if (mThread.joinable())
        mThread.join();
}

void SessionObject::onLastRelease()
{
    if (tInCallback == this)
        throw ApiError(NIMBUS_ERROR_BUSY, "a session cannot be released from its own progress callback; "
                                          "return 0 to cancel and release it after the render returns");
    mCancel = true;
    std::unique_lock<std::mutex> lock(mMutex);
    mDone.wait(lock, [&] { return mState != NIMBUS_SESSION_RUNNING; });  // background or on another thread
    std::thread t = std::move(mThread);
    lock.unlock();
    if (t.joinable())
        t.join();
}

void SessionObject::setProgressCallback(NimbusProgressCallback callback, void* userData)
{
    std::lock_guard<std::mutex> lock(mMutex);
    if (mState == NIMBUS_SESSION_RUNNING)
        throw ApiError(NIMBUS_ERROR_BUSY, "the session is rendering: set the progress callback before it starts");
    std::lock_guard<std::mutex> cb(mCallbackMutex);
    mCallback = callback;
    mUserData = userData;
}

std::shared_ptr<const Scene> SessionObject::begin()
{
    std::shared_ptr<const Scene> scene = mScene->committed();  // NOT_COMMITTED before any state change
    std::lock_guard<std::mutex> lock(mMutex);
    if (mState == NIMBUS_SESSION_RUNNING)
        throw ApiError(NIMBUS_ERROR_BUSY, "the session is already rendering");
    mState = NIMBUS_SESSION_RUNNING;
    mStatus = NIMBUS_OK;
    mMessage.clear();
    mCancel = false;
    mProgress = 0.0f;
    {
        std::lock_guard<std::mutex> cb(mCallbackMutex);
        mProgressReported = 0.0f;
    }
    return scene;
}

bool SessionObject::progress(float fraction)
{
    std::lock_guard<std::mutex> lock(mCallbackMutex);
    if (fraction > mProgressReported)
        mProgressReported = fraction;
    mProgress = mProgressReported;
    if (!mCallback)
        return !mCancel;
    tInCallback = this;
    int keepGoing = 1;
    try {
        keepGoing = mCallback(mProgressReported, mUserData);
    } catch (...) {
        keepGoing = 0;  // a C++ callback that threw: stop rather than unwind through TBB
    }
    tInCallback = nullptr;
    if (!keepGoing)
        mCancel = true;
    return !mCancel;
}

void SessionObject::run(std::shared_ptr<const Scene> scene)
{
    NimbusStatus status = NIMBUS_OK;
    std::string message;
    std::shared_ptr<FrameObject> frame;
    try {
        RenderOptions options;
        options.progress = [this](float f) { return progress(f); };
        options.cancel = &mCancel;
        auto result = std::make_shared<RenderResult>(nimbus::render(*scene, options));
        if (mCancel)  // cancelled after the last tile: the image is complete but was not wanted
            throw Cancelled();
        frame = std::make_shared<FrameObject>(scene, std::move(result));
    } catch (const Cancelled& e) {
        status = NIMBUS_ERROR_CANCELLED, message = e.what();
    } catch (const InputError& e) {
        status = classifyInputError(e.what()), message = e.what();
    } catch (const Error& e) {
        status = NIMBUS_ERROR_RENDER_FAILED, message = e.what();
    } catch (const std::bad_alloc&) {
        status = NIMBUS_ERROR_OUT_OF_MEMORY, message = "out of memory while rendering";
    } catch (const std::exception& e) {
        status = NIMBUS_ERROR_INTERNAL, message = std::string("internal error: ") + e.what();
    } catch (...) {
        status = NIMBUS_ERROR_INTERNAL, message = "internal error: unknown exception";
    }
    std::lock_guard<std::mutex> lock(mMutex);
    mStatus = status;
    mMessage = oneLine(message);
    if (frame) {
        mFrame = std::move(frame);
        mProgress = 1.0f;
    }
    mState = status == NIMBUS_OK ? NIMBUS_SESSION_FINISHED : NIMBUS_SESSION_FAILED;
    mDone.notify_all();
}

NimbusStatus SessionObject::render(std::string& message)
{
    run(begin());
    std::lock_guard<std::mutex> lock(mMutex);
    message = mMessage;
    return mStatus;
}

void SessionObject::start()
{
    std::shared_ptr<const Scene> scene = begin();
    std::thread previous;
    {
        std::lock_guard<std::mutex> lock(mMutex);
        previous = std::move(mThread);  // a finished background render's thread
    }
    if (previous.joinable())
        previous.join();
    try {
        std::thread t([this, scene] { run(scene); });
        std::lock_guard<std::mutex> lock(mMutex);
        mThread = std::move(t);
    } catch (...) {
        std::lock_guard<std::mutex> lock(mMutex);
        mState = NIMBUS_SESSION_FAILED;
        mStatus = NIMBUS_ERROR_RENDER_FAILED;
        mMessage = "cannot start a render thread";
        mDone.notify_all();
        throw ApiError(NIMBUS_ERROR_RENDER_FAILED, mMessage);
    }
}

NimbusStatus SessionObject::wait(double timeoutSeconds, std::string& message)
{
    if (tInCallback == this)
        throw ApiError(NIMBUS_ERROR_BUSY, "a session cannot wait for itself from its own progress callback");
    std::unique_lock<std::mutex> lock(mMutex);
    auto finished = [&] { return mState != NIMBUS_SESSION_RUNNING; };
    if (timeoutSeconds < 0)
        mDone.wait(lock, finished);
    else if (!mDone.wait_for(lock, std::chrono::duration<double>(timeoutSeconds), finished)) {
        message = "the session is still rendering";
        return NIMBUS_ERROR_TIMEOUT;
    }
    if (mState == NIMBUS_SESSION_IDLE) {
        message = "the session has not rendered yet";
        return NIMBUS_ERROR_NOT_FOUND;
    }
    message = mMessage;
    return mStatus;
}

NimbusSessionState SessionObject::state(float* progress) const
{
    std::lock_guard<std::mutex> lock(mMutex);
    if (progress)
        *progress = mProgress;
    return mState;
}

std::shared_ptr<FrameObject> SessionObject::frame() const
{
    std::lock_guard<std::mutex> lock(mMutex);
    if (!mFrame)
        throw ApiError(NIMBUS_ERROR_NOT_FOUND, "the session has no finished render");
    return mFrame;
}

}  // namespace nimbus::api
