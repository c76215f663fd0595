// PCD v0.7 reader (ascii, binary, binary_compressed; any fields) and the binary writers for the data
// set's labelled points and plain xyz clouds. Layouts: docs/formats.md "PCD files".
#include "common/dataset/pcd.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string_view>

namespace teamscan {

static_assert(std::endian::native == std::endian::little, "PCD binary data is written in host order; we assume little-endian");

namespace {

constexpr std::size_t kMaxFields = 4096;

constexpr bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_space(s[i])) ++i;
    const std::size_t start = i;
    while (i < s.size() && !is_space(s[i])) ++i;
    if (i > start) out.push_back(s.substr(start, i - start));
  }
  return out;
}

bool parse_u64(std::string_view s, std::uint64_t& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc{} && r.ptr == s.data() + s.size();
}

bool parse_f64(std::string_view s, double& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc{} && r.ptr == s.data() + s.size();
}

bool valid_type_size(char type, std::uint32_t size) {
  if (type == 'F') return size == 4 || size == 8;
  if (type == 'I' || type == 'U') return size == 1 || size == 2 || size == 4 || size == 8;
  return false;
}

double read_value(const std::uint8_t* p, char type, std::uint32_t size) {
  switch (type) {
    case 'F':
      if (size == 4) { float f; std::memcpy(&f, p, 4); return f; }
      { double d; std::memcpy(&d, p, 8); return d; }
    case 'I':
      switch (size) {
        case 1: { std::int8_t v; std::memcpy(&v, p, 1); return v; }
        case 2: { std::int16_t v; std::memcpy(&v, p, 2); return v; }
        case 4: { std::int32_t v; std::memcpy(&v, p, 4); return v; }
        default: { std::int64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
      }
    default:
      switch (size) {
        case 1: return p[0];
        case 2: { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
        case 4: { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
        default: { std::uint64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
      }
  }
}

Error header_error(const char* what, long line) { return Error{what, 0, line}; }

// Multiplies with an overflow check (sizes declared in a header are untrusted).
bool mul_ok(std::uint64_t a, std::uint64_t b, std::uint64_t& out) {
  if (a != 0 && b > std::numeric_limits<std::uint64_t>::max() / a) return false;
  out = a * b;
  return true;
}

// The labelled layout of points.pcd: name, size, type. Order is the file order (docs/formats.md).
struct LabelledField { const char* name; std::uint32_t size; char type; };
constexpr LabelledField kLabelledFields[] = {
    {"x", 4, 'F'}, {"y", 4, 'F'}, {"z", 4, 'F'}, {"robot", 1, 'U'}, {"scan", 4, 'U'}, {"beam", 2, 'U'},
    {"label", 1, 'U'}, {"hit_robot", 1, 'U'}, {"flags", 2, 'U'}, {"tx", 4, 'F'}, {"ty", 4, 'F'}, {"tz", 4, 'F'}};
constexpr std::size_t kLabelledPointBytes = 35;

std::string header_text(const std::vector<LabelledField>& fields, std::size_t n) {
  std::string names, sizes, types, counts;
  for (const auto& f : fields) {
    names += ' ';
    names += f.name;
    sizes += ' ';
    sizes += std::to_string(f.size);
    types += ' ';
    types += f.type;
    counts += " 1";
  }
  const std::string count = std::to_string(n);
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS" + names + "\nSIZE" + sizes + "\nTYPE" + types +
         "\nCOUNT" + counts + "\nWIDTH " + count + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + count + "\nDATA binary\n";
}

template <class T>
void put(std::uint8_t*& p, T v) {
  std::memcpy(p, &v, sizeof v);
  p += sizeof v;
}

Status write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return Error{"cannot create file", errno};
  const bool wrote = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const int err = errno;
  if (std::fclose(f) != 0 || !wrote) return Error{"write failed", wrote ? errno : err};
  return ok_status();
}

}  // namespace

int PcdCloud::field(const std::string& name) const {
  for (std::size_t i = 0; i < fields.size(); ++i)
    if (fields[i] == name) return static_cast<int>(i);
  return -1;
}

std::uint64_t PcdHeader::point_size_bytes() const {
  std::uint64_t total = 0;
  for (const auto& f : fields) total += std::uint64_t{f.size} * f.count;
  return total;
}

Result<PcdHeader> parse_pcd_header(std::span<const std::uint8_t> bytes) {
  PcdHeader h;
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  bool have_fields = false, have_size = false, have_type = false, have_count = false, have_width = false,
       have_height = false, have_points = false;
  std::vector<std::uint32_t> sizes, counts;
  std::vector<char> types;
  std::size_t pos = 0;
  long line_no = 0;
  while (pos < text.size()) {
    const std::size_t eol = text.find('\n', pos);
    const std::size_t next = eol == std::string_view::npos ? text.size() : eol + 1;
    const std::string_view line = trim(text.substr(pos, next - pos - (eol == std::string_view::npos ? 0 : 1)));
    pos = next;
    ++line_no;
    if (line.empty() || line.front() == '#') continue;
    const auto tok = split_ws(line);
    const std::string_view key = tok[0];
    const std::size_t nargs = tok.size() - 1;
    if (key == "VERSION") {
      if (nargs != 1) return header_error("PCD header: VERSION takes one value", line_no);
    } else if (key == "FIELDS" || key == "COLUMNS") {
      if (nargs == 0 || nargs > kMaxFields) return header_error("PCD header: FIELDS needs 1..4096 names", line_no);
      h.fields.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) h.fields.push_back(PcdField{std::string(tok[i]), 4, 'F', 1});
      have_fields = true;
    } else if (key == "SIZE") {
      sizes.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        std::uint64_t v = 0;
        if (!parse_u64(tok[i], v) || v > 8) return header_error("PCD header: SIZE value is not 1, 2, 4 or 8", line_no);
        sizes.push_back(static_cast<std::uint32_t>(v));
      }
      have_size = true;
    } else if (key == "TYPE") {
      types.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        if (tok[i].size() != 1) return header_error("PCD header: TYPE value is not F, I or U", line_no);
        types.push_back(tok[i][0]);
      }
      have_type = true;
    } else if (key == "COUNT") {
      counts.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        std::uint64_t v = 0;
        if (!parse_u64(tok[i], v) || v == 0 || v > 1u << 20) return header_error("PCD header: COUNT value is not 1..1048576", line_no);
        counts.push_back(static_cast<std::uint32_t>(v));
      }
      have_count = true;
    } else if (key == "WIDTH") {
      if (nargs != 1 || !parse_u64(tok[1], h.width)) return header_error("PCD header: WIDTH is not a non-negative integer", line_no);
      have_width = true;
    } else if (key == "HEIGHT") {
      if (nargs != 1 || !parse_u64(tok[1], h.height)) return header_error("PCD header: HEIGHT is not a non-negative integer", line_no);
      have_height = true;
    } else if (key == "POINTS") {
      if (nargs != 1 || !parse_u64(tok[1], h.points)) return header_error("PCD header: POINTS is not a non-negative integer", line_no);
      have_points = true;
    } else if (key == "VIEWPOINT") {
      if (nargs != 7) return header_error("PCD header: VIEWPOINT takes 7 numbers", line_no);
      for (std::size_t i = 0; i < 7; ++i)
        if (!parse_f64(tok[i + 1], h.viewpoint[i])) return header_error("PCD header: VIEWPOINT value is not a number", line_no);
    } else if (key == "DATA") {
      if (nargs != 1) return header_error("PCD header: DATA takes one of ascii, binary, binary_compressed", line_no);
      if (tok[1] == "ascii") h.data = PcdData::ascii;
      else if (tok[1] == "binary") h.data = PcdData::binary;
      else if (tok[1] == "binary_compressed") h.data = PcdData::binary_compressed;
      else return header_error("PCD header: DATA is not ascii, binary or binary_compressed", line_no);
      h.data_offset = pos;
      // DATA is the last header line: check what the other lines declared, with this line's number.
      if (!have_fields) return header_error("PCD header: no FIELDS line", line_no);
      if (!have_size || !have_type) return header_error("PCD header: no SIZE or TYPE line", line_no);
      if (!have_width || !have_height) return header_error("PCD header: no WIDTH or HEIGHT line", line_no);
      if (sizes.size() != h.fields.size()) return header_error("PCD header: SIZE and FIELDS differ in length", line_no);
      if (types.size() != h.fields.size()) return header_error("PCD header: TYPE and FIELDS differ in length", line_no);
      if (have_count && counts.size() != h.fields.size()) return header_error("PCD header: COUNT and FIELDS differ in length", line_no);
      for (std::size_t i = 0; i < h.fields.size(); ++i) {
        h.fields[i].size = sizes[i];
        h.fields[i].type = types[i];
        h.fields[i].count = have_count ? counts[i] : 1u;
        if (!valid_type_size(types[i], sizes[i])) return header_error("PCD header: invalid TYPE/SIZE pair (F 4|8, I/U 1|2|4|8)", line_no);
      }
      std::uint64_t wh = 0;
      if (!mul_ok(h.width, h.height, wh)) return header_error("PCD header: WIDTH x HEIGHT overflows", line_no);
      if (!have_points) h.points = wh;
      if (wh != h.points) return header_error("PCD header: WIDTH x HEIGHT differs from POINTS", line_no);
      return h;
    } else {
      return header_error("PCD header: unknown keyword (not a PCD v0.7 file?)", line_no);
    }
  }
  return header_error("PCD header: no DATA line", line_no);
}

namespace {

// Decodes the data section into `cloud`, calling `value(point, field)` for each field's first element.
// Point-major for ascii/binary; binary_compressed is field-major after decompression (PCL's layout).
Result<PcdCloud> decode_cloud(const PcdHeader& h, std::span<const std::uint8_t> bytes) {
  PcdCloud cloud;
  cloud.width = h.width;
  cloud.height = h.height;
  std::copy(std::begin(h.viewpoint), std::end(h.viewpoint), std::begin(cloud.viewpoint));
  int ix = -1, iy = -1, iz = -1;
  for (std::size_t i = 0; i < h.fields.size(); ++i) {
    cloud.fields.push_back(h.fields[i].name);
    if (h.fields[i].name == "x") ix = static_cast<int>(i);
    if (h.fields[i].name == "y") iy = static_cast<int>(i);
    if (h.fields[i].name == "z") iz = static_cast<int>(i);
  }
  if (ix < 0 || iy < 0 || iz < 0) return Error{"PCD: no x, y and z fields"};
  const std::size_t nf = h.fields.size();
  cloud.columns.resize(nf);
  const std::uint64_t point_size = h.point_size_bytes();
  const auto data = bytes.subspan(h.data_offset);
  std::vector<double> row(nf);
  auto keep_row = [&] {
    if (!std::isfinite(row[static_cast<std::size_t>(ix)]) || !std::isfinite(row[static_cast<std::size_t>(iy)]) ||
        !std::isfinite(row[static_cast<std::size_t>(iz)]))
      return;  // PCL's convention: a NaN coordinate marks an invalid point (organised clouds)
    cloud.xyz.push_back(static_cast<float>(row[static_cast<std::size_t>(ix)]));
    cloud.xyz.push_back(static_cast<float>(row[static_cast<std::size_t>(iy)]));
    cloud.xyz.push_back(static_cast<float>(row[static_cast<std::size_t>(iz)]));
    for (std::size_t f = 0; f < nf; ++f) cloud.columns[f].push_back(row[f]);
  };

  if (h.data == PcdData::ascii) {
    std::size_t total_values = 0;
    std::vector<std::size_t> first_value(nf);
    for (std::size_t f = 0; f < nf; ++f) {
      first_value[f] = total_values;
      total_values += h.fields[f].count;
    }
    const std::string_view text(reinterpret_cast<const char*>(data.data()), data.size());
    std::size_t pos = 0;
    std::uint64_t read = 0;
    long line_no = 0;
    std::vector<std::string_view> tok;
    while (read < h.points && pos < text.size()) {
      const std::size_t eol = text.find('\n', pos);
      const std::size_t next = eol == std::string_view::npos ? text.size() : eol + 1;
      const std::string_view line = trim(text.substr(pos, next - pos));
      pos = next;
      ++line_no;
      if (line.empty()) continue;
      tok = split_ws(line);
      if (tok.size() != total_values) return Error{"PCD ascii: wrong number of values on a data line", 0, line_no};
      for (std::size_t f = 0; f < nf; ++f) {
        if (!parse_f64(tok[first_value[f]], row[f])) return Error{"PCD ascii: a value is not a number", 0, line_no};
        // A field declared F 4 holds a float: the same value the binary encodings would give.
        if (h.fields[f].type == 'F' && h.fields[f].size == 4) row[f] = static_cast<float>(row[f]);
      }
      keep_row();
      ++read;
    }
    if (read < h.points) return Error{"PCD ascii: truncated data (fewer lines than POINTS)", 0, static_cast<long>(read)};
    return cloud;
  }

  std::uint64_t data_bytes = 0;
  if (point_size == 0 || !mul_ok(h.points, point_size, data_bytes)) return Error{"PCD: POINTS x point size overflows"};
  std::vector<std::uint64_t> offset(nf);
  {
    std::uint64_t o = 0;
    for (std::size_t f = 0; f < nf; ++f) {
      offset[f] = o;
      o += std::uint64_t{h.fields[f].size} * h.fields[f].count;
    }
  }

  if (h.data == PcdData::binary) {
    if (data.size() < data_bytes) return Error{"PCD binary: truncated data (file shorter than POINTS x point size)", 0, static_cast<long>(data.size() / point_size)};
    cloud.xyz.reserve(3 * h.points);
    for (auto& c : cloud.columns) c.reserve(h.points);
    for (std::uint64_t i = 0; i < h.points; ++i) {
      const std::uint8_t* p = data.data() + i * point_size;
      for (std::size_t f = 0; f < nf; ++f) row[f] = read_value(p + offset[f], h.fields[f].type, h.fields[f].size);
      keep_row();
    }
    return cloud;
  }

  // binary_compressed: uint32 compressed size, uint32 uncompressed size, LZF block of the field-major data.
  if (data.size() < 8) return Error{"PCD binary_compressed: truncated (no block sizes)"};
  std::uint32_t compressed = 0, uncompressed = 0;
  std::memcpy(&compressed, data.data(), 4);
  std::memcpy(&uncompressed, data.data() + 4, 4);
  if (data.size() - 8 < compressed) return Error{"PCD binary_compressed: truncated compressed block", 0, static_cast<long>(data.size() - 8)};
  if (uncompressed != data_bytes) return Error{"PCD binary_compressed: uncompressed size differs from POINTS x point size", 0, static_cast<long>(uncompressed)};
  // LZF expands at most 264 bytes per 3 input bytes: a larger claim is corrupt, so refuse it before allocating.
  if (uncompressed > std::uint64_t{compressed} * 88u + 64u) return Error{"PCD binary_compressed: uncompressed size impossible for the block"};
  std::vector<std::uint8_t> plain(uncompressed);
  const auto n = lzf_decompress(data.subspan(8, compressed), plain);
  if (!n) return n.error();
  if (*n != uncompressed) return Error{"PCD binary_compressed: block decompresses to the wrong size", 0, static_cast<long>(*n)};
  cloud.xyz.reserve(3 * h.points);
  for (auto& c : cloud.columns) c.reserve(h.points);
  for (std::uint64_t i = 0; i < h.points; ++i) {
    for (std::size_t f = 0; f < nf; ++f) {
      const std::uint64_t elem = std::uint64_t{h.fields[f].size} * h.fields[f].count;
      row[f] = read_value(plain.data() + h.points * offset[f] + i * elem, h.fields[f].type, h.fields[f].size);
    }
    keep_row();
  }
  return cloud;
}

}  // namespace

Result<PcdCloud> parse_pcd(std::span<const std::uint8_t> bytes) {
  const auto h = parse_pcd_header(bytes);
  if (!h) return h.error();
  return decode_cloud(*h, bytes);
}

Result<std::vector<std::uint8_t>> read_file_bytes(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return Error{"cannot open file", errno};
  std::vector<std::uint8_t> bytes;
  std::uint8_t buf[1 << 16];
  for (;;) {
    const std::size_t n = std::fread(buf, 1, sizeof buf, f);
    bytes.insert(bytes.end(), buf, buf + n);
    if (n < sizeof buf) break;
  }
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return Error{"read failed", errno};
  return bytes;
}

Result<PcdCloud> read_pcd(const std::string& path) {
  const auto bytes = read_file_bytes(path);
  if (!bytes) return bytes.error();
  return parse_pcd(*bytes);
}

std::vector<std::uint8_t> encode_labelled_pcd(std::span<const LabelledPoint> points) {
  const std::string header =
      header_text(std::vector<LabelledField>(std::begin(kLabelledFields), std::end(kLabelledFields)), points.size());
  std::vector<std::uint8_t> out(header.size() + points.size() * kLabelledPointBytes);
  std::memcpy(out.data(), header.data(), header.size());
  std::uint8_t* p = out.data() + header.size();
  for (const auto& q : points) {
    put(p, q.x); put(p, q.y); put(p, q.z);
    put(p, q.robot); put(p, q.scan); put(p, q.beam);
    put(p, static_cast<std::uint8_t>(q.label)); put(p, q.hit_robot); put(p, q.flags);
    put(p, q.tx); put(p, q.ty); put(p, q.tz);
  }
  return out;
}

Status write_labelled_pcd(const std::string& path, std::span<const LabelledPoint> points) {
  return write_bytes(path, encode_labelled_pcd(points));
}

std::vector<std::uint8_t> encode_xyz_pcd(std::span<const float> xyz) {
  TEAMSCAN_EXPECTS(xyz.size() % 3 == 0);
  const std::string header = header_text({{"x", 4, 'F'}, {"y", 4, 'F'}, {"z", 4, 'F'}}, xyz.size() / 3);
  std::vector<std::uint8_t> out(header.size() + xyz.size() * 4);
  std::memcpy(out.data(), header.data(), header.size());
  if (!xyz.empty()) std::memcpy(out.data() + header.size(), xyz.data(), xyz.size() * 4);
  return out;
}

Status write_xyz_pcd(const std::string& path, std::span<const float> xyz) { return write_bytes(path, encode_xyz_pcd(xyz)); }

Result<std::vector<std::uint8_t>> encode_pcd(const PcdCloud& cloud, const std::vector<PcdField>& layout_in, PcdData data) {
  const std::size_t nf = cloud.fields.size();
  if (nf == 0 || cloud.columns.size() != nf) return Error{"PCD write: fields and columns differ in number"};
  const std::size_t n = cloud.columns[0].size();
  for (const auto& c : cloud.columns)
    if (c.size() != n) return Error{"PCD write: columns differ in length"};
  if (cloud.field("x") < 0 || cloud.field("y") < 0 || cloud.field("z") < 0) return Error{"PCD write: no x, y and z fields"};
  if (data == PcdData::binary_compressed) return Error{"PCD write: binary_compressed is not supported (use binary)"};
  std::vector<PcdField> layout = layout_in;
  if (layout.empty())
    for (const auto& name : cloud.fields) layout.push_back(PcdField{name, 4, 'F', 1});
  if (layout.size() != nf) return Error{"PCD write: layout and fields differ in number"};
  for (std::size_t f = 0; f < nf; ++f) {
    if (layout[f].name != cloud.fields[f]) return Error{"PCD write: layout names differ from the fields"};
    if (!valid_type_size(layout[f].type, layout[f].size) || layout[f].count != 1)
      return Error{"PCD write: invalid TYPE/SIZE (F 4|8, I/U 1|2|4|8) or COUNT other than 1"};
    const auto& field_name = layout[f].name;
    if (field_name.empty() || field_name.find_first_of(" \t\r\n") != std::string::npos) return Error{"PCD write: a field name is empty or has white space"};
  }
  // Integer fields: the value rounded to nearest must fit the type.
  for (std::size_t f = 0; f < nf; ++f) {
    if (layout[f].type == 'F') continue;
    const double bits = 8.0 * layout[f].size;
    const double lo = layout[f].type == 'U' ? 0.0 : -std::ldexp(1.0, static_cast<int>(bits) - 1);
    // Exclusive upper bound, a power of two and so exact in a double (2^64 - 1 is not).
    const double hi_excl = layout[f].type == 'U' ? std::ldexp(1.0, static_cast<int>(bits)) : std::ldexp(1.0, static_cast<int>(bits) - 1);
    for (std::size_t i = 0; i < n; ++i) {
      const double v = std::nearbyint(cloud.columns[f][i]);
      if (!(v >= lo && v < hi_excl)) return Error{"PCD write: an integer field's value does not fit its type", 0, static_cast<long>(i)};
    }
  }
  char vp[256];
  std::snprintf(vp, sizeof vp, "%.17g %.17g %.17g %.17g %.17g %.17g %.17g", cloud.viewpoint[0], cloud.viewpoint[1], cloud.viewpoint[2],
                cloud.viewpoint[3], cloud.viewpoint[4], cloud.viewpoint[5], cloud.viewpoint[6]);
  std::string header = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (const auto& f : layout) header += " " + f.name;
  header += "\nSIZE";
  for (const auto& f : layout) header += " " + std::to_string(f.size);
  header += "\nTYPE";
  for (const auto& f : layout) header += std::string(" ") + f.type;
  header += "\nCOUNT";
  for (std::size_t f = 0; f < nf; ++f) header += " 1";
  const bool organised = cloud.width * cloud.height == n && cloud.height > 1;
  header += "\nWIDTH " + std::to_string(organised ? cloud.width : n) + "\nHEIGHT " + std::to_string(organised ? cloud.height : 1) +
            "\nVIEWPOINT " + vp + "\nPOINTS " + std::to_string(n) + "\nDATA " + (data == PcdData::ascii ? "ascii" : "binary") + "\n";
  std::vector<std::uint8_t> out(header.begin(), header.end());
  if (data == PcdData::ascii) {
    std::string line;
    char buf[40];
    for (std::size_t i = 0; i < n; ++i) {
      line.clear();
      for (std::size_t f = 0; f < nf; ++f) {
        const double v = cloud.columns[f][i];
        if (layout[f].type == 'F')
          std::snprintf(buf, sizeof buf, layout[f].size == 4 ? "%.9g" : "%.17g", layout[f].size == 4 ? static_cast<double>(static_cast<float>(v)) : v);
        else
          std::snprintf(buf, sizeof buf, "%.0f", std::nearbyint(v));
        if (f != 0) line += ' ';
        line += buf;
      }
      line += '\n';
      out.insert(out.end(), line.begin(), line.end());
    }
    return out;
  }
  std::uint64_t point_size = 0;
  for (const auto& f : layout) point_size += f.size;
  const std::size_t start = out.size();
  out.resize(start + n * point_size);
  std::uint8_t* p = out.data() + start;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t f = 0; f < nf; ++f) {
      const double v = cloud.columns[f][i];
      const double r = std::nearbyint(v);
      switch (layout[f].type) {
        case 'F':
          if (layout[f].size == 4) put(p, static_cast<float>(v)); else put(p, v);
          break;
        case 'I':
          switch (layout[f].size) {
            case 1: put(p, static_cast<std::int8_t>(r)); break;
            case 2: put(p, static_cast<std::int16_t>(r)); break;
            case 4: put(p, static_cast<std::int32_t>(r)); break;
            default: put(p, static_cast<std::int64_t>(r)); break;
          }
          break;
        default:
          switch (layout[f].size) {
            case 1: put(p, static_cast<std::uint8_t>(r)); break;
            case 2: put(p, static_cast<std::uint16_t>(r)); break;
            case 4: put(p, static_cast<std::uint32_t>(r)); break;
            default: put(p, static_cast<std::uint64_t>(r)); break;
          }
      }
    }
  return out;
}

Status write_pcd(const std::string& path, const PcdCloud& cloud, const std::vector<PcdField>& layout, PcdData data) {
  const auto bytes = encode_pcd(cloud, layout, data);
  if (!bytes) return bytes.error();
  return write_bytes(path, *bytes);
}

Result<std::vector<LabelledPoint>> parse_labelled_pcd(std::span<const std::uint8_t> bytes) {
  const auto h = parse_pcd_header(bytes);
  if (!h) return h.error();
  bool own_layout = h->data == PcdData::binary && h->fields.size() == std::size(kLabelledFields);
  for (std::size_t i = 0; own_layout && i < h->fields.size(); ++i) {
    const auto& f = h->fields[i];
    own_layout = f.name == kLabelledFields[i].name && f.size == kLabelledFields[i].size && f.type == kLabelledFields[i].type && f.count == 1;
  }
  std::vector<LabelledPoint> points;
  if (own_layout) {
    const auto data = bytes.subspan(h->data_offset);
    if (data.size() / kLabelledPointBytes < h->points)
      return Error{"PCD binary: truncated data (file shorter than POINTS x point size)", 0, static_cast<long>(data.size() / kLabelledPointBytes)};
    points.reserve(h->points);
    for (std::uint64_t i = 0; i < h->points; ++i) {
      const std::uint8_t* p = data.data() + i * kLabelledPointBytes;
      LabelledPoint q;
      std::uint8_t label = 0;
      std::memcpy(&q.x, p + 0, 4); std::memcpy(&q.y, p + 4, 4); std::memcpy(&q.z, p + 8, 4);
      q.robot = p[12];
      std::memcpy(&q.scan, p + 13, 4);
      std::memcpy(&q.beam, p + 17, 2);
      label = p[19];
      q.hit_robot = p[20];
      std::memcpy(&q.flags, p + 21, 2);
      std::memcpy(&q.tx, p + 23, 4); std::memcpy(&q.ty, p + 27, 4); std::memcpy(&q.tz, p + 31, 4);
      if (label > static_cast<std::uint8_t>(PointClass::robot)) return Error{"PCD: label out of range (0..5)", 0, static_cast<long>(i)};
      q.label = static_cast<PointClass>(label);
      if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) continue;  // as the generic reader
      points.push_back(q);
    }
    return points;
  }
  // Any other layout: the generic reader, then the twelve fields by name.
  auto cloud = decode_cloud(*h, bytes);
  if (!cloud) return cloud.error();
  int idx[std::size(kLabelledFields)];
  for (std::size_t i = 0; i < std::size(kLabelledFields); ++i) {
    idx[i] = cloud->field(kLabelledFields[i].name);
    if (idx[i] < 0) return Error{"PCD: a labelled-point field is missing (x y z robot scan beam label hit_robot flags tx ty tz)"};
  }
  const auto col = [&](std::size_t field, std::size_t i) { return cloud->columns[static_cast<std::size_t>(idx[field])][i]; };
  // Integer fields read as double: refuse values the C++ field cannot hold (a cast would be undefined).
  const auto in_range = [](double v, double max) { return v >= 0 && v <= max && v == std::floor(v); };
  points.reserve(cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    LabelledPoint q;
    q.x = cloud->xyz[3 * i]; q.y = cloud->xyz[3 * i + 1]; q.z = cloud->xyz[3 * i + 2];
    if (!in_range(col(6, i), 5)) return Error{"PCD: label out of range (0..5)", 0, static_cast<long>(i)};
    if (!in_range(col(3, i), 255) || !in_range(col(4, i), 4294967295.0) || !in_range(col(5, i), 65535) ||
        !in_range(col(7, i), 255) || !in_range(col(8, i), 65535))
      return Error{"PCD: robot, scan, beam, hit_robot or flags out of its type's range", 0, static_cast<long>(i)};
    q.robot = static_cast<std::uint8_t>(col(3, i));
    q.scan = static_cast<std::uint32_t>(col(4, i));
    q.beam = static_cast<std::uint16_t>(col(5, i));
    q.label = static_cast<PointClass>(static_cast<std::uint8_t>(col(6, i)));
    q.hit_robot = static_cast<std::uint8_t>(col(7, i));
    q.flags = static_cast<std::uint16_t>(col(8, i));
    q.tx = static_cast<float>(col(9, i)); q.ty = static_cast<float>(col(10, i)); q.tz = static_cast<float>(col(11, i));
    points.push_back(q);
  }
  return points;
}

Result<std::vector<LabelledPoint>> read_labelled_pcd(const std::string& path) {
  const auto bytes = read_file_bytes(path);
  if (!bytes) return bytes.error();
  return parse_labelled_pcd(*bytes);
}

}  // namespace teamscan
