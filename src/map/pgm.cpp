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

class PgmParser {
 public:
  PgmParser(const std::string& path, std::string bytes) : path_(path), bytes_(std::move(bytes)) {}

  MapImage parse() {
    if (bytes_.size() < 2 || bytes_[0] != 'P' || (bytes_[1] != '5' && bytes_[1] != '2')) {
      throw MapError(path_, "header",
                     "not a PGM or PNG file (expected magic P5 or P2, or a PNG, found '" + bytes_.substr(0, 2) + "')");
    }
    const bool binary = bytes_[1] == '5';
    pos_ = 2;
    MapImage image;
    image.width = static_cast<int>(headerNumber("width", 1, 1 << 20));
    image.height = static_cast<int>(headerNumber("height", 1, 1 << 20));
    const long maxval = headerNumber("maxval", 1, 65535);
    const size_t count = static_cast<size_t>(image.width) * image.height;
    if (count > kMaxMapCells) {
      throw MapError(path_, "header", std::to_string(image.width) + " x " + std::to_string(image.height) + " = " +
                                          std::to_string(count) + " cells, more than the " +
                                          std::to_string(kMaxMapCells) + " a map may have (a 250 m square at 0.05 m)");
    }
    image.pixels.resize(count);

    if (binary) {
      // Exactly one whitespace character separates maxval from the samples.
      ++pos_;
      const size_t sample_bytes = maxval < 256 ? 1 : 2;
      const size_t needed = count * sample_bytes;
      const size_t available = pos_ <= bytes_.size() ? bytes_.size() - pos_ : 0;
      if (available < needed) {
        throw MapError(path_, "pixels",
                       "truncated: expected " + std::to_string(needed) + " bytes, found " + std::to_string(available));
      }
      const auto* data = reinterpret_cast<const unsigned char*>(bytes_.data() + pos_);
      for (size_t i = 0; i < count; ++i) {
        const long sample = sample_bytes == 1 ? data[i] : (data[2 * i] << 8 | data[2 * i + 1]);
        image.pixels[i] = scaled(sample, maxval);
      }
    } else {
      for (size_t i = 0; i < count; ++i) {
        const long sample = number("pixels", "sample " + std::to_string(i));
        if (sample > maxval) {
          throw MapError(path_, "pixels",
                         "sample " + std::to_string(i) + " is " + std::to_string(sample) + ", above maxval " +
                             std::to_string(maxval));
        }
        image.pixels[i] = scaled(sample, maxval);
      }
    }
    return image;
  }

 private:
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
    const long value = number("header", what);
    if (value < min || value > max) {
      throw MapError(path_, "header",
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
