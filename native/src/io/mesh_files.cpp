#include "volpath/mesh_files.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>
#include <fstream>
#include <functional>
#include <string_view>
#include <unordered_map>

namespace volpath {

namespace {

std::string read_all(const std::string &path) {
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    if (!f) throw MeshFileError(path + ": cannot read the file");
    std::string text(size_t(f.tellg()), '\0');
    f.seekg(0);
    f.read(text.data(), std::streamsize(text.size()));
    if (!f) throw MeshFileError(path + ": cannot read the file");
    return text;
}

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// The whitespace-separated fields of one line.
struct Fields {
    const char *p, *end;
    bool next(std::string_view &field) {
        while (p < end && is_blank(*p)) ++p;
        if (p == end) return false;
        const char *start = p;
        while (p < end && !is_blank(*p)) ++p;
        field = {start, size_t(p - start)};
        return true;
    }
};

template <class T>
bool parse(std::string_view s, T &x) {
    if (!s.empty() && s[0] == '+') s.remove_prefix(1);
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
    return ec == std::errc() && ptr == s.data() + s.size();
}

// The 0-based index of an OBJ face corner's field (1-based, or negative: from the end of
// the `count` so far), -1 when the field is empty.
bool obj_index(std::string_view field, size_t count, int64_t &index) {
    if (field.empty()) return index = -1, true;
    int64_t k;
    if (!parse(field, k)) return false;
    index = k > 0 ? k - 1 : int64_t(count) + k;
    return 0 <= index && index < int64_t(count);
}

struct CornerHash {
    size_t operator()(const std::array<int64_t, 3> &c) const {
        const uint64_t h = uint64_t(c[0]) * 0x9E3779B97F4A7C15ull ^ uint64_t(c[1] + 1) * 0xC2B2AE3D27D4EB4Full ^
                           uint64_t(c[2] + 1) * 0x165667B19E3779F9ull;
        return size_t(h ^ (h >> 31));
    }
};

void fan(const std::vector<int64_t> &polygon, std::vector<int64_t> &triangles) {
    for (size_t i = 1; i + 1 < polygon.size(); ++i)
        triangles.insert(triangles.end(), {polygon[0], polygon[i], polygon[i + 1]});
}

}  // namespace

MeshArrays read_obj(const std::string &path) {
    const std::string text = read_all(path);
    std::vector<double> v, vt, vn;
    // Each corner's vertex (-1: none yet): one with a position alone (the common "f 1 2 3")
    // found by its index, others by (v, vt, vn).
    std::vector<int64_t> plain;
    std::unordered_map<std::array<int64_t, 3>, int64_t, CornerHash> corners;
    MeshArrays out;
    bool every_uv = true, every_normal = true;
    std::vector<int64_t> polygon;
    int line = 0;
    for (const char *p = text.data(), *end = p + text.size(); p < end;) {
        const char *eol = static_cast<const char *>(std::memchr(p, '\n', size_t(end - p)));
        if (!eol) eol = end;
        ++line;
        Fields fields{p, eol};
        p = eol + 1;
        std::string_view key, field;
        if (!fields.next(key) || key[0] == '#') continue;
        const auto fail = [&](const std::string &what) {
            throw MeshFileError(path + ":" + std::to_string(line) + ": " + what);
        };
        // `required` numbers, then up to `optional` more (absent: `fallback`); the rest ignored.
        const auto numbers = [&](std::vector<double> &to, int required, int optional, double fallback) {
            for (int i = 0; i < required + optional; ++i) {
                double x = fallback;
                if (fields.next(field) ? !parse(field, x) : i < required)
                    fail("malformed '" + std::string(key) + "' line (expected numbers)");
                to.push_back(x);
            }
        };
        if (key == "v") {
            numbers(v, 3, 0, 0);
        } else if (key == "vn") {
            numbers(vn, 3, 0, 0);
        } else if (key == "vt") {
            numbers(vt, 1, 1, 0);
            vt.back() = 1 - vt.back();
        } else if (key == "f") {
            polygon.clear();
            while (fields.next(field)) {
                std::array<int64_t, 3> corner{-1, -1, -1};
                const size_t counts[3] = {v.size() / 3, vt.size() / 2, vn.size() / 3};
                size_t start = 0;
                for (int i = 0; i < 3 && start <= field.size(); ++i) {
                    const size_t slash = std::min(field.find('/', start), field.size());
                    if (!obj_index(field.substr(start, slash - start), counts[i], corner[i]))
                        fail("face refers to a missing vertex");
                    start = slash + 1;
                }
                if (corner[0] < 0) fail("face refers to a missing vertex");
                if (corner[1] < 0 && corner[2] < 0 && plain.size() <= size_t(corner[0])) plain.resize(v.size() / 3, -1);
                int64_t &vertex =
                    corner[1] < 0 && corner[2] < 0 ? plain[corner[0]] : corners.try_emplace(corner, -1).first->second;
                if (vertex < 0) {
                    vertex = int64_t(out.positions.size() / 3);
                    out.positions.insert(out.positions.end(), &v[3 * corner[0]], &v[3 * corner[0]] + 3);
                    every_uv &= corner[1] >= 0, every_normal &= corner[2] >= 0;
                    if (corner[1] >= 0) out.uvs.insert(out.uvs.end(), &vt[2 * corner[1]], &vt[2 * corner[1]] + 2);
                    if (corner[2] >= 0)
                        out.normals.insert(out.normals.end(), &vn[3 * corner[2]], &vn[3 * corner[2]] + 3);
                }
                polygon.push_back(vertex);
            }
            if (polygon.size() < 3) fail("a face needs at least 3 vertices");
            fan(polygon, out.triangles);
        }
    }
    if (!every_uv) out.uvs.clear();
    if (!every_normal) out.normals.clear();
    return out;
}

namespace {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

bool ply_type(std::string_view name, PlyType &type) {
    static const std::pair<std::string_view, PlyType> kNames[] = {
        {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::UInt8},
        {"uint8", PlyType::UInt8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
        {"ushort", PlyType::UInt16},  {"uint16", PlyType::UInt16},   {"int", PlyType::Int32},
        {"int32", PlyType::Int32},    {"uint", PlyType::UInt32},     {"uint32", PlyType::UInt32},
        {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
        {"float64", PlyType::Float64}};
    for (const auto &[n, t] : kNames)
        if (n == name) return type = t, true;
    return false;
}

struct PlyProperty {
    std::string name;
    bool list = false;
    PlyType count_type = PlyType::UInt8, type = PlyType::Float32;
};

struct PlyElement {
    std::string name;
    int64_t count = 0;
    std::vector<PlyProperty> properties;
};

// The values of a PLY body, one at a time, in its encoding.
struct PlyBody {
    enum Format { Ascii, LittleEndian, BigEndian };
    const std::string &path;
    Format format;
    const char *p, *end;
    int line;  // ASCII only: where p is
    std::string element;

    [[noreturn]] void fail(const std::string &what) const {
        throw MeshFileError(path + (format == Ascii ? ":" + std::to_string(line) : "") + ": " + what);
    }

    double read(PlyType type) {
        if (format == Ascii) {
            while (p < end && (is_blank(*p) || *p == '\n')) line += *p++ == '\n';
            const char *start = p;
            while (p < end && !is_blank(*p) && *p != '\n') ++p;
            double x;
            if (start == p) fail("the file ends inside element '" + element + "'");
            if (!parse(std::string_view(start, size_t(p - start)), x))
                fail("malformed number '" + std::string(start, p) + "' in element '" + element + "'");
            return x;
        }
        static constexpr size_t kSizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
        const size_t n = kSizes[int(type)];
        if (size_t(end - p) < n) fail("the file ends inside element '" + element + "'");
        unsigned char bytes[8];
        std::memcpy(bytes, p, n);
        p += n;
        static const bool host_little = [] {
            const uint16_t one = 1;
            return *reinterpret_cast<const unsigned char *>(&one) == 1;
        }();
        if ((format == LittleEndian) != host_little) std::reverse(bytes, bytes + n);
        switch (type) {
            case PlyType::Int8:
                return as<int8_t>(bytes);
            case PlyType::UInt8:
                return as<uint8_t>(bytes);
            case PlyType::Int16:
                return as<int16_t>(bytes);
            case PlyType::UInt16:
                return as<uint16_t>(bytes);
            case PlyType::Int32:
                return as<int32_t>(bytes);
            case PlyType::UInt32:
                return as<uint32_t>(bytes);
            case PlyType::Float32:
                return as<float>(bytes);
            case PlyType::Float64:
                return as<double>(bytes);
        }
        return 0;
    }

    template <class T>
    static double as(const unsigned char *bytes) {
        T x;
        std::memcpy(&x, bytes, sizeof(T));
        return double(x);
    }
};

// Where each of the vertex element's properties goes: (array, component), or nowhere.
struct VertexSlot {
    std::vector<double> *to = nullptr;
    int component = 0, width = 0;
};

// The names PLY writers give texture coordinates (Blender, Mitsuba, MeshLab).
constexpr std::pair<const char *, const char *> kUVNames[] = {
    {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};

std::vector<VertexSlot> vertex_slots(const PlyElement &vertex, MeshArrays &out, const std::string &path) {
    const auto find = [&](const char *name) {
        for (size_t i = 0; i < vertex.properties.size(); ++i)
            if (!vertex.properties[i].list && vertex.properties[i].name == name) return int(i);
        return -1;
    };
    std::vector<VertexSlot> slots(vertex.properties.size());
    const auto assign = [&](std::initializer_list<const char *> names, std::vector<double> &to) {
        std::vector<int> at;
        for (const char *name : names) at.push_back(find(name));
        if (std::find(at.begin(), at.end(), -1) != at.end()) return false;
        for (size_t c = 0; c < at.size(); ++c) slots[at[c]] = {&to, int(c), int(at.size())};
        to.resize(size_t(vertex.count) * at.size());
        return true;
    };
    if (!assign({"x", "y", "z"}, out.positions))
        throw MeshFileError(path + ": the PLY vertex element needs properties x, y and z");
    assign({"nx", "ny", "nz"}, out.normals);
    for (const auto &[u, v] : kUVNames)
        if (assign({u, v}, out.uvs)) break;
    return slots;
}

// The header's elements with their properties, the body's encoding and where it starts.
struct PlyHeader {
    std::vector<PlyElement> elements;
    PlyBody::Format encoding = PlyBody::Ascii;
    size_t body_start = 0;
    int body_line = 0;  // the body's first line number
};

// One header line's element or property, added to `elements`.
void read_ply_declaration(std::string_view key, Fields &fields, std::vector<PlyElement> &elements,
                          const std::function<void(const std::string &)> &fail) {
    std::string_view a, b, c, d;
    if (key == "element") {
        PlyElement e;
        if (!fields.next(a) || !fields.next(b) || !parse(b, e.count) || e.count < 0)
            fail("expected 'element <name> <count>'");
        e.name = a;
        elements.push_back(std::move(e));
        return;
    }
    if (elements.empty()) fail("property before any element");
    PlyProperty p;
    if (!fields.next(a) || !fields.next(b)) fail("expected 'property <type> <name>'");
    if (a == "list") {
        if (!fields.next(c) || !fields.next(d)) fail("expected 'property list <count type> <type> <name>'");
        p.list = true, p.name = d;
        if (!ply_type(b, p.count_type) || !ply_type(c, p.type)) fail("unknown type of property '" + p.name + "'");
    } else {
        p.name = b;
        if (!ply_type(a, p.type)) fail("unknown type of property '" + p.name + "'");
    }
    elements.back().properties.push_back(std::move(p));
}

PlyHeader read_ply_header(const std::string &data, const std::string &path) {
    const size_t header_end = data.find("end_header");
    if (data.compare(0, 3, "ply") != 0 || header_end == std::string::npos)
        throw MeshFileError(path + ": not a PLY file (missing 'ply' magic or 'end_header')");
    PlyHeader header;
    std::string format;
    int line = 0;
    for (size_t at = 0; at < header_end;) {
        const size_t eol = std::min(data.find('\n', at), header_end);
        ++line;
        Fields fields{data.data() + at, data.data() + eol};
        at = eol + 1;
        const auto fail = [&](const std::string &what) {
            throw MeshFileError(path + ":" + std::to_string(line) + ": " + what);
        };
        std::string_view key, a;
        if (!fields.next(key)) continue;
        if (key == "format") {
            fields.next(a);
            format = a;
        } else if (key == "element" || key == "property") {
            read_ply_declaration(key, fields, header.elements, fail);
        }
    }
    if (format == "ascii")
        header.encoding = PlyBody::Ascii;
    else if (format == "binary_little_endian")
        header.encoding = PlyBody::LittleEndian;
    else if (format == "binary_big_endian")
        header.encoding = PlyBody::BigEndian;
    else
        throw MeshFileError(path + ": unknown PLY format '" + format + "'");
    // The body starts on the line after end_header's (its line: the header's lines + 2).
    const size_t body = data.find('\n', header_end);
    header.body_start = body == std::string::npos ? data.size() : body + 1;
    header.body_line = line + 2;
    return header;
}

// One element's rows: a vertex's positions, normals and uvs into `out` (slots), a face's
// vertex indices as a fan of triangles; other elements are read past.
void read_ply_rows(PlyBody &in, const PlyElement &e, const std::vector<VertexSlot> &slots, MeshArrays &out) {
    const bool vertex = e.name == "vertex", face = e.name == "face";
    std::vector<int64_t> polygon;
    for (int64_t row = 0; row < e.count; ++row) {
        for (size_t k = 0; k < e.properties.size(); ++k) {
            const PlyProperty &p = e.properties[k];
            if (!p.list) {
                const double x = in.read(p.type);
                if (vertex && slots[k].to) (*slots[k].to)[size_t(row) * slots[k].width + slots[k].component] = x;
                continue;
            }
            const double n = in.read(p.count_type);
            if (!(n >= 0 && n == int64_t(n))) in.fail("a list's length must be a count, got " + std::to_string(n));
            const bool indices = face && (p.name == "vertex_indices" || p.name == "vertex_index");
            if (indices) polygon.clear();
            for (int64_t i = 0; i < int64_t(n); ++i) {
                const double x = in.read(p.type);
                if (indices) polygon.push_back(int64_t(x));
            }
            if (indices) fan(polygon, out.triangles);
        }
    }
}

}  // namespace

MeshArrays read_ply(const std::string &path) {
    const std::string data = read_all(path);
    const PlyHeader header = read_ply_header(data, path);
    PlyBody in{path, header.encoding, data.data() + header.body_start, data.data() + data.size(), header.body_line, ""};
    MeshArrays out;
    bool has_vertices = false, has_faces = false;
    for (const PlyElement &e : header.elements) {
        in.element = e.name;
        const bool vertex = e.name == "vertex";
        has_vertices |= vertex, has_faces |= e.name == "face";
        read_ply_rows(in, e, vertex ? vertex_slots(e, out, path) : std::vector<VertexSlot>(), out);
    }
    if (!has_vertices || !has_faces) throw MeshFileError(path + ": PLY file needs 'vertex' and 'face' elements");
    return out;
}

}  // namespace volpath
