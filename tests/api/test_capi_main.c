/* test_capi_main.c: runs the C ABI tests. Arguments: the torus plugin, the broken plugin, a
 * writable directory. Exit status 0 when every check passed. */
#include "CapiTest.h"

int gPassed = 0, gFailed = 0;

int main(int argc, char** argv)
{
    TestPaths paths;
    if (argc != 4) {
        fprintf(stderr, "usage: %s TORUS_PLUGIN BROKEN_PLUGIN WORK_DIR\n", argv[0]);
        return 2;
    }
    paths.torusPlugin = argv[1];
    paths.brokenPlugin = argv[2];
    paths.workDir = argv[3];
    testRender(&paths);
    testMisuse(&paths);
    printf("%d passed, %d failed\n", gPassed, gFailed);
    return gFailed == 0 ? 0 : 1;
}
