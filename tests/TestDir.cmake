# NIMBUS_TEST_DIR (tests/TestDir.h) for a test executable: `dir` in one generated source of its
# own, so that no other object's command line holds the checkout's path (ccache, scripts/build.sh).
function(nimbus_test_dir target dir)
  set(file ${CMAKE_CURRENT_BINARY_DIR}/${target}_test_dir.cpp)
  file(GENERATE OUTPUT ${file} CONTENT "extern \"C\" const char nimbus_test_dir[] = \"${dir}\";\n")
  target_sources(${target} PRIVATE ${file})
endfunction()
