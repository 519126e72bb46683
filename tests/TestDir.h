// TestDir.h: NIMBUS_TEST_DIR, the absolute path of the folder holding a test's sources (its data
// files beside it). Defined in one generated file per test executable (nimbus_test in
// tests/CMakeLists.txt), not as a compile definition: a path in every test object's command line
// made a fresh clone's objects miss ccache.
#pragma once

extern "C" const char nimbus_test_dir[];

#define NIMBUS_TEST_DIR nimbus_test_dir
