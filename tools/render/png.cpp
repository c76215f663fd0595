// PNG encoding through libpng: 8-bit RGB, no time or text chunks, fixed compression settings, so the
// same image always gives the same bytes.
#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>

#include "tools/render/render.hpp"

namespace teamscan::render {
namespace {

void append_bytes(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + length);
}
void no_flush(png_structp) {}

// Kept free of C++ objects with destructors between setjmp and longjmp (libpng's error path).
bool encode(const Image& image, std::vector<std::uint8_t>* out, std::vector<png_bytep>* rows) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {  // NOLINT(cert-err52-cpp): libpng reports errors by longjmp
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, out, append_bytes, no_flush);
  png_set_compression_level(png, 6);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width_px), static_cast<png_uint_32>(image.height_px), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_image(png, rows->data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

Result<std::vector<std::uint8_t>> encode_png(const Image& image) {
  if (image.width_px <= 0 || image.height_px <= 0 ||
      image.rgb.size() != 3 * static_cast<std::size_t>(image.width_px) * static_cast<std::size_t>(image.height_px))
    return Error{"PNG: image size and pixel buffer disagree"};
  std::vector<std::uint8_t> out;
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height_px));
  for (int y = 0; y < image.height_px; ++y)
    rows[static_cast<std::size_t>(y)] =
        const_cast<png_bytep>(image.rgb.data() + 3 * static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width_px));  // NOLINT: libpng only reads
  if (!encode(image, &out, &rows)) return Error{"PNG: libpng failed to encode the image"};
  return out;
}

Status write_png(const std::string& path, const Image& image) {
  const auto bytes = encode_png(image);
  if (!bytes) return bytes.error();
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return Error{"cannot create PNG file", errno};
  const bool wrote = std::fwrite(bytes->data(), 1, bytes->size(), f) == bytes->size();
  const int err = errno;
  if (std::fclose(f) != 0 || !wrote) return Error{"PNG write failed", wrote ? errno : err};
  return ok_status();
}

}  // namespace teamscan::render
