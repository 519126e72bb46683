// OpenImageFile.h: an image file opened with the reader its extension names, and no other.
//
// OpenImageIO's ImageInput::open() tries every reader it has when the one the extension names
// refuses the file (its global attribute try_all_readers, left as it is: a host application
// embedding nimbus may rely on it). A damaged `.exr` then reaches the Radiance, DICOM, FITS, PNM,
// ... readers, each a parser of its own (fuzz_envmap, 2026-12-06: a Radiance header in a file
// named .exr, which the .hdr reader read as 2^31 - 1 pixels wide). A map whose extension names a
// format is read as that format or refused; a name without a known extension is left to
// OpenImageIO's own choice, as before.
#pragma once

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cctype>
#include <memory>
#include <string>

namespace nimbus {

// The open reader, or null with `error` set (OpenImageIO's message, one line).
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

}  // namespace nimbus
