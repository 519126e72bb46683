/* CapiTest.h: a minimal test harness for the C ABI tests (C99, no framework: the point is that
 * a plain C compiler can use nimbus.h). Each CHECK counts; a failure prints the file, line, the
 * expression and nimbus_last_error(), and the run ends with "N passed, N failed". */
#ifndef NIMBUS_CAPI_TEST_H
#define NIMBUS_CAPI_TEST_H

#include "nimbus.h"

#include <stdio.h>
#include <string.h>

extern int gPassed, gFailed;

#define CHECK(cond)                                                                                                    \
    do {                                                                                                               \
        if (cond) {                                                                                                    \
            ++gPassed;                                                                                                 \
        } else {                                                                                                       \
            ++gFailed;                                                                                                 \
            fprintf(stderr, "%s:%d: CHECK(%s) failed; last error: %s\n", __FILE__, __LINE__, #cond,                    \
                    nimbus_last_error());                                                                              \
        }                                                                                                              \
    } while (0)

/* A call that must succeed. */
#define OK(call) CHECK_STATUS(call, NIMBUS_OK)

/* A call that must return `expected` and, for an error, leave a non-empty message. */
#define CHECK_STATUS(call, expected)                                                                                   \
    do {                                                                                                               \
        NimbusStatus s_ = (call);                                                                                      \
        if (s_ == (expected) && ((expected) == NIMBUS_OK || nimbus_last_error()[0] != '\0')) {                         \
            ++gPassed;                                                                                                 \
        } else {                                                                                                       \
            ++gFailed;                                                                                                 \
            fprintf(stderr, "%s:%d: %s returned %s, expected %s; last error: '%s'\n", __FILE__, __LINE__, #call,       \
                    nimbus_status_name(s_), nimbus_status_name(expected), nimbus_last_error());                        \
        }                                                                                                              \
    } while (0)

/* The last error names `text` (e.g. the parameter or key path). */
#define CHECK_MESSAGE(text)                                                                                            \
    do {                                                                                                               \
        if (strstr(nimbus_last_error(), (text))) {                                                                     \
            ++gPassed;                                                                                                 \
        } else {                                                                                                       \
            ++gFailed;                                                                                                 \
            fprintf(stderr, "%s:%d: last error '%s' does not contain '%s'\n", __FILE__, __LINE__, nimbus_last_error(), \
                    (text));                                                                                           \
        }                                                                                                              \
    } while (0)

/* Paths given on the command line (tests/api/CMakeLists.txt). */
typedef struct TestPaths {
    const char* torusPlugin;  /* build/lib/libnimbus_torus.so */
    const char* brokenPlugin; /* a library without nimbus_volume_sample */
    const char* workDir;      /* a writable directory */
} TestPaths;

/* A small scene built through the API: a procedural sphere lit by a distant light, 32 x 24. */
NimbusScene makeTestScene(int width, int height, int spp);

void testRender(const TestPaths* paths);
void testMisuse(const TestPaths* paths);

#endif
