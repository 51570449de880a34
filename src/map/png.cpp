// PNG reading with libpng, handing the pixels over as map_server's loader (SDL_image) does, and
// the choice between PNG and PGM by a file's first bytes.
#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"

namespace marl_mrta {
namespace map {

namespace {

constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

// libpng's read state; libpng reports errors by longjmp to the reader's setjmp, with the message
// kept here.
struct PngReadState {
  png_structp png = nullptr;
  png_infop info = nullptr;
  char message[256] = "";

  ~PngReadState() { png_destroy_read_struct(&png, info ? &info : nullptr, nullptr); }
};

void onPngError(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngReadState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof(state->message), "%s", message);
  png_longjmp(png, 1);
}

void onPngWarning(png_structp, png_const_charp) {}  // e.g. colour profile notes: not the map's concern

// fread for libpng, with a message that says what went wrong (libpng's own says "Read Error").
void readPngBytes(png_structp png, png_bytep data, png_size_t length) {
  if (std::fread(data, 1, length, static_cast<FILE*>(png_get_io_ptr(png))) != length) png_error(png, "file truncated");
}

}  // namespace

MapImage readPng(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) throw MapError(path, "file", std::string("cannot open (") + std::strerror(errno) + ")");
  PngReadState state;
  state.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state, onPngError, onPngWarning);
  if (state.png != nullptr) state.info = png_create_info_struct(state.png);
  if (state.png == nullptr || state.info == nullptr) throw MapError(path, "PNG", "out of memory");

  // Only `state` (addressed) is read after a longjmp; nothing declared before this point changes.
  if (setjmp(png_jmpbuf(state.png))) throw MapError(path, "PNG", state.message);
  png_set_read_fn(state.png, file.get(), readPngBytes);
  png_read_info(state.png, state.info);
  const png_uint_32 width = png_get_image_width(state.png, state.info);
  const png_uint_32 height = png_get_image_height(state.png, state.info);
  const int color_type = png_get_color_type(state.png, state.info);
  const int bit_depth = png_get_bit_depth(state.png, state.info);
  if (static_cast<size_t>(width) * height > kMaxMapCells) {
    throw MapError(path, "PNG header", std::to_string(width) + " x " + std::to_string(height) + " = " +
                                           std::to_string(static_cast<size_t>(width) * height) +
                                           " cells, more than the " + std::to_string(kMaxMapCells) +
                                           " a map may have (a 250 m square at 0.05 m)");
  }
  if (color_type == PNG_COLOR_TYPE_PALETTE) {
    throw MapError(path, "PNG",
                   "a palette image; map_server reads its palette indices as grey values, not its colours: "
                   "save the map as greyscale or RGB");
  }
  // SDL_image's transformations: 8-bit samples (16-bit keep the high byte); grey expanded, so that
  // small depths scale to 0..255 and a transparent grey (tRNS) becomes an alpha channel (grey +
  // alpha, 2 channels); grey + alpha as RGBA. An RGB image's tRNS adds no channel.
  png_set_strip_16(state.png);
  png_set_packing(state.png);
  if (color_type == PNG_COLOR_TYPE_GRAY) png_set_expand(state.png);
  if (color_type == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(state.png);
  png_read_update_info(state.png, state.info);

  MapImage image;
  image.width = static_cast<int>(width);
  image.height = static_cast<int>(height);
  image.channels = png_get_channels(state.png, state.info);
  const size_t row_bytes = png_get_rowbytes(state.png, state.info);
  if (row_bytes != static_cast<size_t>(width) * image.channels) {
    throw MapError(path, "PNG", "unexpected row size " + std::to_string(row_bytes) + " bytes for " +
                                    std::to_string(width) + " pixels of " + std::to_string(image.channels) +
                                    " channels");
  }
  image.pixels.resize(row_bytes * height);
  std::vector<png_bytep> rows(height);
  for (png_uint_32 row = 0; row < height; ++row) rows[row] = image.pixels.data() + row * row_bytes;

  // From here libpng writes only into the buffers above; an error jumps back here. Nothing after
  // the image data is read (no png_read_end), as SDL_image: a file without IEND is a map there.
  if (setjmp(png_jmpbuf(state.png))) throw MapError(path, "PNG", state.message);
  png_read_image(state.png, rows.data());
  return image;
}

MapImage readMapImage(const std::string& path) {
  unsigned char head[sizeof(kPngSignature)] = {};
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw MapError(path, "file", std::string("cannot open (") + std::strerror(errno) + ")");
    in.read(reinterpret_cast<char*>(head), sizeof(head));
  }
  if (std::memcmp(head, kPngSignature, sizeof(kPngSignature)) == 0) return readPng(path);
  return readPgm(path);
}

}  // namespace map
}  // namespace marl_mrta
