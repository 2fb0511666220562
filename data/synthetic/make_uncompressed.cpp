// Writes uncompressed.vdb: plume-a frame 24's density re-saved by OpenVDB with no
// compression at all (not even active-mask compression), to test haze's importer on
// uncompressed files. Build and run (Debian: libopenvdb-dev):
//   g++ -std=c++17 -O1 make_uncompressed.cpp -o /tmp/make_uncompressed -lopenvdb -ltbb
//   /tmp/make_uncompressed ../plume-a/vdb/fluid_data_0024.vdb uncompressed.vdb
#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Compression.h>

int main(int argc, char** argv) {
    if (argc != 3) return 2;
    openvdb::initialize();
    openvdb::io::File in(argv[1]);
    in.open();
    openvdb::GridBase::Ptr base = in.readGrid("density");
    in.close();
    openvdb::GridPtrVec grids{base};
    openvdb::io::File out(argv[2]);
    out.setCompression(openvdb::io::COMPRESS_NONE);
    out.write(grids);
    out.close();
    return 0;
}
