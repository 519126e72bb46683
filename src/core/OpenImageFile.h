// OpenImageFile.h: an environment or depth map opened for reading, every check made before
// OpenImageIO or the loader allocates what the file claims (issue 18, items 4 and 5).
//
// Three checks, in the order a damaged file meets them:
//  1. the header's claims against the file's size, before OpenImageIO parses it
//     (imageHeaderProblem, ImageFileCheck.h: OpenEXR allocates what a header says);
//  2. the reader its extension names, and no other: OpenImageIO's ImageInput::open() tries every
//     reader it has when that one refuses the file (its global try_all_readers, left as it is: a
//     host application embedding nimbus may rely on it), so a damaged `.exr` reached the
//     Radiance, DICOM, FITS, PNM, ... parsers (fuzz_envmap, 2026-12-06: a Radiance header in a
//     file named .exr, read as 2^31 - 1 pixels wide). A name without an extension OpenImageIO
//     knows is left to OpenImageIO's own choice;
//  3. the image the reader reports (2-D, width x height x channels) against the file's size and
//     the loader's bytes against render.memory_limit (imagePixelsProblem).
#pragma once

#include "ImageFileCheck.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cctype>
#include <functional>
#include <memory>
#include <string>

namespace nimbus {

// The reader for `path` (check 2), or null with `error` set to OpenImageIO's message.
inline std::unique_ptr<OIIO::ImageInput> openImageFile(const std::string& path, std::string& error)
{
    std::string format = OIIO::Filesystem::extension(path, false);
    for (char& c : format)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    // create() given a bare extension makes that format's reader and opens nothing.
    OIIO::ImageInput::unique_ptr in = format.empty() ? nullptr : OIIO::ImageInput::create(format);
    if (!in) {
        (void)OIIO::geterror();  // no extension OpenImageIO knows: its own choice
        in = OIIO::ImageInput::open(path);
        if (!in)
            error = OIIO::geterror();
        return in;
    }
    OIIO::ImageSpec spec;
    if (!in->open(path, spec)) {
        error = in->geterror();
        if (error.empty())
            error = "not a file of the format its extension '." + format + "' names";
        return nullptr;
    }
    return in;
}

// The open reader of a map that passed all three checks, or null with `error` set to why not:
// one line without the file's name, for the caller to prefix with its key and the file.
// `loaderBytesPerPixel(channels)`: what the loader holds at once per pixel of a file of that
// many channels (its reading buffer and what it keeps); `limitBytes`: render.memory_limit.
inline std::unique_ptr<OIIO::ImageInput> openCheckedImage(const std::string& path,
                                                          const std::function<double(int)>& loaderBytesPerPixel,
                                                          size_t limitBytes, std::string& error)
{
    error = imageHeaderProblem(path);
    std::unique_ptr<OIIO::ImageInput> in = error.empty() ? openImageFile(path, error) : nullptr;
    if (in) {
        const OIIO::ImageSpec& is = in->spec();
        if (is.width < 1 || is.height < 1 || is.depth > 1)
            error = "it is not a 2-D image";
        else
            error = imagePixelsProblem(path, is.width, is.height, is.nchannels, loaderBytesPerPixel(is.nchannels),
                                       limitBytes);
        if (!error.empty())
            in.reset();
    } else if (error.empty()) {
        error = "OpenImageIO cannot read it";
    }
    // OpenImageIO's messages may span lines; an input error is one.
    for (char& c : error)
        if (c == '\n' || c == '\r')
            c = ' ';
    return in;
}

}  // namespace nimbus
