// PGM (netpbm grey map) reading, binary P5 and ASCII P2, enough for map_server maps.
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "marl_mrta/map/occupancy_map.h"

namespace marl_mrta {
namespace map {

namespace {

// A file's first bytes for a one-line message: printable ASCII as it is, other bytes as \xNN.
std::string printable(const std::string& bytes) {
  static const char kHex[] = "0123456789abcdef";
  std::string out;
  for (const char c : bytes) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7f) {
      out += c;
    } else {
      out += std::string("\\x") + kHex[u >> 4] + kHex[u & 15];
    }
  }
  return out;
}

class PgmParser {
 public:
  PgmParser(const std::string& path, std::string bytes) : path_(path), bytes_(std::move(bytes)) {}

  MapImage parse() {
    if (bytes_.size() < 2 || bytes_[0] != 'P' || (bytes_[1] != '5' && bytes_[1] != '2')) {
      throw MapError(path_, "PGM header",
                     "not a PGM or PNG file (expected magic P5 or P2, or a PNG, found '" +
                         printable(bytes_.substr(0, 2)) + "')");
    }
    const bool binary = bytes_[1] == '5';
    pos_ = 2;
    MapImage image;
    image.width = static_cast<int>(headerNumber("width", 1, 1 << 20));
    image.height = static_cast<int>(headerNumber("height", 1, 1 << 20));
    // As map_server's loader (SDL_image): at most 8 bits; a smaller maxval is scaled to 0..255.
    const long maxval = number("PGM header", "maxval");
    if (maxval < 1 || maxval > 255) {
      throw MapError(path_, "PGM header",
                     "maxval " + std::to_string(maxval) + ": map_server reads PGMs of 8 bits or fewer (maxval 1 to 255)");
    }
    const size_t count = static_cast<size_t>(image.width) * image.height;
    if (count > kMaxMapCells) {
      throw MapError(path_, "PGM header", std::to_string(image.width) + " x " + std::to_string(image.height) + " = " +
                                          std::to_string(count) + " cells, more than the " +
                                          std::to_string(kMaxMapCells) + " a map may have (a 250 m square at 0.05 m)");
    }
    image.pixels.resize(count);

    if (binary) {
      // Exactly one whitespace character separates maxval from the samples.
      ++pos_;
      const size_t needed = count;
      const size_t available = pos_ <= bytes_.size() ? bytes_.size() - pos_ : 0;
      if (available < needed) {
        throw MapError(path_, "PGM data",
                       "truncated: expected " + std::to_string(needed) + " bytes, found " + std::to_string(available));
      }
      const auto* data = reinterpret_cast<const unsigned char*>(bytes_.data() + pos_);
      for (size_t i = 0; i < count; ++i) image.pixels[i] = scaled(data[i], maxval);
    } else {
      for (size_t i = 0; i < count; ++i) {
        const long sample = number("PGM data", "sample " + std::to_string(i));
        if (sample > maxval) {
          throw MapError(path_, "PGM data",
                         "sample " + std::to_string(i) + " is " + std::to_string(sample) + ", above maxval " +
                             std::to_string(maxval));
        }
        image.pixels[i] = scaled(sample, maxval);
      }
    }
    return image;
  }

 private:
  // SDL_image's scaling, into a byte (a binary sample above maxval wraps, as it does there).
  static uint8_t scaled(long sample, long maxval) {
    return static_cast<uint8_t>(maxval == 255 ? sample : sample * 255 / maxval);
  }

  void skipSpaceAndComments() {
    while (pos_ < bytes_.size()) {
      const char c = bytes_[pos_];
      if (c == '#') {
        while (pos_ < bytes_.size() && bytes_[pos_] != '\n') ++pos_;
      } else if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f') {
        ++pos_;
      } else {
        return;
      }
    }
  }

  long number(const std::string& field, const std::string& what) {
    skipSpaceAndComments();
    if (pos_ >= bytes_.size()) throw MapError(path_, field, "file ends before " + what);
    long value = 0;
    size_t digits = 0;
    while (pos_ < bytes_.size() && bytes_[pos_] >= '0' && bytes_[pos_] <= '9' && digits < 9) {
      value = value * 10 + (bytes_[pos_] - '0');
      ++pos_;
      ++digits;
    }
    if (digits == 0) throw MapError(path_, field, what + " is not a number");
    return value;
  }

  long headerNumber(const std::string& what, long min, long max) {
    const long value = number("PGM header", what);
    if (value < min || value > max) {
      throw MapError(path_, "PGM header",
                     what + " " + std::to_string(value) + " out of range [" + std::to_string(min) + ", " +
                         std::to_string(max) + "]");
    }
    return value;
  }

  std::string path_;
  std::string bytes_;
  size_t pos_ = 0;
};

}  // namespace

MapImage readPgm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapError(path, "file", std::string("cannot open (") + std::strerror(errno) + ")");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return PgmParser(path, std::move(bytes)).parse();
}

}  // namespace map
}  // namespace marl_mrta
