// TempFiles.h: the temporary files being written right now (AtomicFile's), so that a process
// killed by SIGINT or SIGTERM in the middle of a write leaves none behind.
//
// The registry is a fixed table of path buffers: the signal handler may only call
// async-signal-safe functions (unlink, sigaction, raise), so it cannot take a lock or allocate.
// A path longer than the buffer, or a write beyond the table's size, is simply not registered
// (the file is still removed by AtomicFile on every other way out).
//
// Library code registers; only a program that owns its signals (the nimbus CLI) installs the
// handlers: a host application embedding nimbus keeps its own.
#pragma once

namespace nimbus {

// Registers `path` (made absolute) as a live temporary file; returns its slot, or -1 when it
// could not be registered.
int registerTempFile(const char* path);

// Forgets the slot (after the file was renamed or removed). -1 is ignored.
void unregisterTempFile(int slot);

// Installs handlers for SIGINT, SIGTERM and SIGHUP that unlink every registered file, restore
// the default action and re-raise the signal, so the process still dies of it (exit status
// 128 + signal for a shell).
void removeTempFilesOnSignals();

}  // namespace nimbus
