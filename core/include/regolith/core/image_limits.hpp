#pragma once
// Image sizes regolith accepts anywhere: cameras (V4L2, libcamera, mocks), the rover description,
// scene and drive files, the algorithms' constructors. One place, so that a camera a backend opens
// is never refused by the component that reads its frames. Dependency-free.

#include <cstdint>

namespace regolith {

/// The largest image side any camera here takes (V4L2, libcamera, rover description, scene files).
inline constexpr int kMaxImageSidePx = 16384;

/// Most pixels regolith decodes in one image: 2^26 (e.g. 8192 x 8192; every camera regolith drives
/// is below 21 Mpx). `regolith assess` needs ~65 bytes of working maps per pixel (measured on a
/// 3000 x 2000 image: 394 MB resident), so this bound keeps one image under ~4.5 GB.
inline constexpr std::uint64_t kMaxImagePixels = std::uint64_t{1} << 26;

}  // namespace regolith
