// fuzz_nvdb: a NanoVDB file's bytes (.nvdb) through the volume loader (issue 18, item 5: each new
// loader gets a harness): NanoVdbFileReader (the file and grid headers, the codecs' payloads, the
// tree's node tables), then everything after the read as fuzz_vdb has it (role grids, resampling,
// clamping, bricks; a file that loads is loaded again with velocity blur). `vdb` sources pick the
// reader by extension (src/volume/VdbLoad.cpp), so this is fuzz_vdb.cpp with the input written as
// .nvdb. Corpus: tests/fuzz/corpus/nvdb, the vdb seeds converted by vdb_tool (make_seeds.py).
#define NIMBUS_FUZZ_VDB_EXTENSION ".nvdb"
#include "fuzz_vdb.cpp"
