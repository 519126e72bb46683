// ImageFileCheck.h: what an image file's header claims, checked against the file's size before
// OpenImageIO reads it (issue 18, items 4 and 5: memory known before it is spent).
//
// Why: OpenEXR and OpenImageIO allocate what a header says before reading the data it
// describes. fuzz_envmap's first minutes found a 298-byte EXR whose string attribute claimed
// 1.9 GB (OpenEXR 3.1 resized the string, then failed to read it: seconds of memset and 2 GB of
// memory for a file that is then refused), and a data window can claim 2^31 x 2^31 pixels, whose
// chunk offset table OpenEXR allocates on open and whose pixels the loaders allocate before
// reading them. A file can only hold so much: each attribute's bytes must be in the file, the
// offset table (8 bytes a chunk) too, and the pixels at most a compression's largest ratio times
// the file's size. The same bound for Radiance .hdr files (run-length coding, at most 64:1).
// The walk must read the header where OpenEXR's C++ reader does: it takes a channel list up to
// its empty name and a fixed-size value (box2i, int, tiledesc, ...) whole, whatever the size
// field says, so an attribute whose size field disagrees with its value is refused (a 204-byte
// file whose channel list "of 55 bytes" took 24 sent OpenEXR to an opaque attribute of 842 MB).
// A tile may take at most 64 MiB (OpenEXR allocates a tile's buffers and its compressor's when
// it opens a tiled file: a 508-byte file with 8 x 2^24 tiles took 1 to 2 GB).
// Other formats (TIFF, PNG, ...): imagePixelsProblem, once OpenImageIO has read the header.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace nimbus {

// The most any image format's pixels (4-byte channels) exceed the file's bytes: DWA's, a flat
// 8x8 block kept as one DCT coefficient before deflate. Deflate (PNG, TIFF, EXR ZIP) stays near
// 1032:1 and JPEG near 1536:1.
constexpr double kMaxImageRatio = 100000.0;

// Empty when the file is not an OpenEXR or Radiance file, cannot be opened (the reader says
// why), or its header describes no more than the file can hold; else why not, one line without
// the file's name (e.g. "its header attribute 'comments' claims 1936269428 bytes where 270 are
// left (truncated or damaged)").
std::string imageHeaderProblem(const std::string& path);

// Once a reader has opened the file (any format) and before its pixels are allocated: the
// width x height x channels it reports against the file's size (at most kMaxImageRatio) and the
// loader's bytes (`loaderBytesPerPixel` a pixel, the reading buffer and what is kept) against
// render.memory_limit (`limitBytes`). Empty when both hold; else why not, one line without the
// file's name. (A Radiance header that OpenImageIO reads as 2^31 - 1 pixels wide: fuzz_envmap.)
std::string imagePixelsProblem(const std::string& path, int64_t width, int64_t height, int channels,
                               double loaderBytesPerPixel, size_t limitBytes);

}  // namespace nimbus
