// Preview.h: an 8-bit sRGB PNG of the beauty AOV for review (dailies pages, farm thumbnails).
//
// The beauty is scene-linear Rec.709; it goes through an OpenColorIO display/view transform.
// The config is, first found: PreviewOptions::config, $OCIO, $NIMBUS_OCIO_CONFIG, then the one
// shipped in src/io/ocio/config.ocio (display "sRGB", views "ACES 1.0 - SDR Video" (the default,
// a filmic tone scale that rolls bright highlights off), "Standard" (the plain sRGB curve) and
// "Raw"). The scene's output.preview_view, .preview_look and .exposure pick the options.
// Alpha is ignored: the beauty is premultiplied, so its RGB is the composite over black.
#pragma once

#include <string>

namespace nimbus {

struct Film;

struct PreviewOptions {
    std::string display;    // empty: the config's default display
    std::string view;       // empty: the display's default view
    std::string look;       // an OCIO look applied before the view (replacing the view's own); empty: none
    float exposure = 0.0f;  // stops; scales scene-linear values by 2^exposure before the view
    std::string config;     // an OCIO config file; empty: $OCIO, $NIMBUS_OCIO_CONFIG, the shipped one
};

// Checks, without writing anything, that the config loads and has the display, view and look:
// an InputError "<where>: <key>: ..." naming the scene key (output.preview for the config or the
// display, output.preview_view, output.preview_look), the config and the valid choices.
void checkPreviewSettings(const PreviewOptions& options, const std::string& where);

// Writes the full frame (pixels outside the crop black) through a temporary file renamed over
// `path`; missing parent directories are created. On any failure throws Error (one line naming
// `path`, or the config that failed to load) and leaves an existing file at `path` untouched.
void writePreview(const Film& film, const std::string& path, const PreviewOptions& options = {});

}  // namespace nimbus
