// volpath._vdb: reads OpenVDB files (Debian's libopenvdb) into Volpath's sparse layout,
// and writes that layout back as OpenVDB files.
// A separate module so that volpath._core stays free of OpenVDB, TBB and Boost; it runs in
// a child process (volpath/vdb.py), because OpenVDB trusts its input.
//
// OpenVDB's leaves are 8^3 voxels, as are Volpath's bricks: the grid is placed so that
// leaves fall exactly on bricks, and each leaf is copied as one brick (x fastest inside,
// where OpenVDB keeps z fastest). Active tiles of inner nodes are expanded into bricks.
#include <pybind11/pybind11.h>

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace py = pybind11;

namespace {

constexpr int kBrick = 8;
// A brick index larger than this (a 2048^3 bounding box) is refused before allocation.
constexpr size_t kMaxBricks = size_t(1) << 24;

template <typename T>
struct Channels {
    static constexpr int value = 1;
};
template <typename T>
struct Channels<openvdb::math::Vec3<T>> {
    static constexpr int value = 3;
};

float channel(float v, int) { return v; }
float channel(double v, int) { return float(v); }
template <typename T>
float channel(const openvdb::math::Vec3<T> &v, int c) {
    return float(v[c]);
}

// What a grid becomes: Volpath's brick layout and the index-to-world matrix (column vectors).
struct Bricks {
    std::array<int32_t, 3> res{}, origin{}, bricks{};
    int32_t channels = 1;
    double index_to_world[16] = {};
    std::vector<int32_t> index;
    std::vector<float> data;
};

template <typename GridT>
Bricks read_grid(const GridT &grid) {
    using ValueT = typename GridT::ValueType;
    constexpr int C = Channels<ValueT>::value;
    if (!openvdb::math::isZero(grid.background()))
        throw std::invalid_argument("the grid's background value is not zero (expected a fog volume)");
    const openvdb::CoordBBox active = grid.evalActiveVoxelBoundingBox();
    if (active.empty()) throw std::invalid_argument("the grid has no active voxels");
    // One zero voxel of margin on each side keeps the border clamp of lookups at zero;
    // the origin on a multiple of 8 puts leaves on bricks.
    Bricks out;
    out.channels = C;
    auto &origin = out.origin, &res = out.res, &bricks = out.bricks;
    for (int a = 0; a < 3; ++a) {
        const int lo = active.min()[a] - 1, hi = active.max()[a] + 1;
        origin[a] = int(std::floor(lo / double(kBrick))) * kBrick;
        bricks[a] = (hi - origin[a]) / kBrick + 1;
        res[a] = bricks[a] * kBrick;
    }
    const size_t brick_count = size_t(bricks[0]) * bricks[1] * bricks[2];
    if (brick_count > kMaxBricks)
        throw std::invalid_argument("the active bounding box is too large (more than 2048^3 voxels)");
    auto &index = out.index;
    auto &data = out.data;
    index.assign(brick_count, -1);
    auto brick_of = [&](const openvdb::Coord &ijk) -> float * {
        const int bx = (ijk.x() - origin[0]) / kBrick, by = (ijk.y() - origin[1]) / kBrick,
                  bz = (ijk.z() - origin[2]) / kBrick;
        int32_t &slot = index[(size_t(bz) * bricks[1] + by) * bricks[0] + bx];
        if (slot < 0) {
            slot = int32_t(data.size() / (kBrick * kBrick * kBrick * C));
            data.resize(data.size() + size_t(kBrick) * kBrick * kBrick * C, 0.0f);
        }
        return data.data() + size_t(slot) * kBrick * kBrick * kBrick * C;
    };
    auto put = [&](const openvdb::Coord &ijk, const ValueT &v) {
        float *b = brick_of(ijk);
        const int x = ijk.x() & (kBrick - 1), y = ijk.y() & (kBrick - 1), z = ijk.z() & (kBrick - 1);
        for (int c = 0; c < C; ++c) b[((z * kBrick + y) * kBrick + x) * C + c] = channel(v, c);
    };
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        if (it.isVoxelValue()) {
            put(it.getCoord(), *it);
            continue;
        }
        const openvdb::CoordBBox tile = it.getBoundingBox();
        if (tile.volume() > uint64_t(kMaxBricks) * 64)
            throw std::invalid_argument("an active tile is too large to expand");
        for (auto ijk = tile.begin(); ijk; ++ijk) put(*ijk, *it);
    }

    const openvdb::math::Transform &xf = grid.transform();
    if (!xf.isLinear())
        throw std::invalid_argument("the grid's transform is not linear (frustum grids are not supported)");
    const openvdb::Mat4d m = xf.baseMap()->getAffineMap()->getMat4();  // row vectors: world = ijk * m
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) out.index_to_world[i * 4 + j] = m(j, i);
    return out;
}

openvdb::io::File open_file(const std::string &path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open(false);  // no delayed loading: the file is read once and closed
    return file;
}

Bricks read_bricks(const std::string &path, const std::string &name) {
    auto file = open_file(path);
    if (!file.hasGrid(name)) {
        std::string names;
        for (auto it = file.beginName(); it != file.endName(); ++it) names += (names.empty() ? "'" : ", '") + *it + "'";
        throw std::invalid_argument("no grid named '" + name + "' (the file has " + (names.empty() ? "none" : names) +
                                    ")");
    }
    openvdb::GridBase::Ptr base = file.readGrid(name);
    file.close();
    if (base->getGridClass() == openvdb::GRID_LEVEL_SET)
        throw std::invalid_argument("the grid is a level set (expected a fog volume)");
    if (auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) return read_grid(*g);
    if (auto g = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) return read_grid(*g);
    if (auto g = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base)) return read_grid(*g);
    if (auto g = openvdb::gridPtrCast<openvdb::Vec3DGrid>(base)) return read_grid(*g);
    throw std::invalid_argument("grid type '" + base->valueType() +
                                "' is not supported (expected float, double or vec3)");
}

// The bricks as a little-endian file that volpath/vdb.py reads with numpy (the reading
// process needs neither numpy nor the volpath package, so it starts fast): "VPVDB1\0\0",
// res[3], origin[3], channels (int32), stored bricks (int64), index_to_world
// (16 doubles, row-major), the brick index (int32), the bricks (float32).
void save(const std::string &path, const std::string &name, const std::string &out_path) {
    const Bricks b = read_bricks(path, name);
    std::unique_ptr<FILE, int (*)(FILE *)> f(std::fopen(out_path.c_str(), "wb"), &std::fclose);
    if (!f) throw std::runtime_error("cannot write " + out_path);
    const int64_t stored = int64_t(b.data.size() / (size_t(kBrick) * kBrick * kBrick * b.channels));
    bool ok = std::fwrite("VPVDB1\0\0", 1, 8, f.get()) == 8;
    ok &= std::fwrite(b.res.data(), 4, 3, f.get()) == 3 && std::fwrite(b.origin.data(), 4, 3, f.get()) == 3;
    ok &= std::fwrite(&b.channels, 4, 1, f.get()) == 1;
    ok &= std::fwrite(&stored, 8, 1, f.get()) == 1 && std::fwrite(b.index_to_world, 8, 16, f.get()) == 16;
    ok &= std::fwrite(b.index.data(), 4, b.index.size(), f.get()) == b.index.size();
    ok &= std::fwrite(b.data.data(), 4, b.data.size(), f.get()) == b.data.size();
    if (!ok) throw std::runtime_error("cannot write " + out_path + " (disk full?)");
}

// The reverse of save: a brick file (the same layout, written by volpath/vdb.py) becomes
// a one-grid .vdb file, a fog volume whose non-zero voxels are active.
Bricks load(const std::string &path) {
    std::unique_ptr<FILE, int (*)(FILE *)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) throw std::runtime_error("cannot read " + path);
    Bricks b;
    char magic[8];
    int64_t stored = 0;
    bool ok = std::fread(magic, 1, 8, f.get()) == 8 && std::equal(magic, magic + 8, "VPVDB1\0\0");
    ok = ok && std::fread(b.res.data(), 4, 3, f.get()) == 3 && std::fread(b.origin.data(), 4, 3, f.get()) == 3;
    ok = ok && std::fread(&b.channels, 4, 1, f.get()) == 1 && (b.channels == 1 || b.channels == 3);
    ok = ok && std::fread(&stored, 8, 1, f.get()) == 1 && std::fread(b.index_to_world, 8, 16, f.get()) == 16;
    size_t count = 1;
    for (int a = 0; a < 3 && ok; ++a) {
        ok = b.res[a] > 0;
        b.bricks[a] = (b.res[a] + kBrick - 1) / kBrick;
        count *= size_t(b.bricks[a]);
    }
    ok = ok && count <= kMaxBricks && stored >= 0 && size_t(stored) <= count;
    if (!ok) throw std::invalid_argument(path + ": not a brick file");
    b.index.resize(count);
    b.data.resize(size_t(stored) * kBrick * kBrick * kBrick * b.channels);
    ok = std::fread(b.index.data(), 4, count, f.get()) == count &&
         std::fread(b.data.data(), 4, b.data.size(), f.get()) == b.data.size();
    if (!ok) throw std::invalid_argument(path + ": truncated brick file");
    return b;
}

template <typename GridT>
typename GridT::Ptr grid_from_bricks(const Bricks &b) {
    using ValueT = typename GridT::ValueType;
    constexpr int C = Channels<ValueT>::value;
    auto grid = GridT::create(openvdb::zeroVal<ValueT>());
    auto access = grid->getAccessor();
    for (int bz = 0; bz < b.bricks[2]; ++bz)
        for (int by = 0; by < b.bricks[1]; ++by)
            for (int bx = 0; bx < b.bricks[0]; ++bx) {
                const int32_t slot = b.index[(size_t(bz) * b.bricks[1] + by) * b.bricks[0] + bx];
                if (slot < 0) continue;
                if (size_t(slot) >= b.data.size() / (size_t(kBrick) * kBrick * kBrick * C))
                    throw std::invalid_argument("a brick index points past the stored bricks");
                const float *brick = b.data.data() + size_t(slot) * kBrick * kBrick * kBrick * C;
                for (int z = 0; z < kBrick; ++z)
                    for (int y = 0; y < kBrick; ++y)
                        for (int x = 0; x < kBrick; ++x) {
                            const float *v = brick + ((z * kBrick + y) * kBrick + x) * C;
                            ValueT value;
                            if constexpr (C == 1)
                                value = v[0];
                            else
                                value = ValueT(v[0], v[1], v[2]);
                            if (openvdb::math::isZero(value)) continue;
                            access.setValue(openvdb::Coord(b.origin[0] + bx * kBrick + x, b.origin[1] + by * kBrick + y,
                                                           b.origin[2] + bz * kBrick + z),
                                            value);
                        }
            }
    return grid;
}

void write_vdb(const std::string &brick_path, const std::string &name, const std::string &out_path) {
    openvdb::initialize();
    const Bricks b = load(brick_path);
    openvdb::GridBase::Ptr grid;
    if (b.channels == 1)
        grid = grid_from_bricks<openvdb::FloatGrid>(b);
    else
        grid = grid_from_bricks<openvdb::Vec3SGrid>(b);
    openvdb::Mat4d m;  // row vectors: world = ijk * m
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) m(j, i) = b.index_to_world[i * 4 + j];
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    grid->setName(name);
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    openvdb::io::File file(out_path);
    file.write({grid});
    file.close();
}

}  // namespace

PYBIND11_MODULE(_vdb, m) {
    m.doc() = "OpenVDB files read into Volpath's sparse brick layout, and written from it.";
    // OpenVDB reports bad files with its own exceptions (IoError, KeyError, ...); all say what.
    // A truncated or corrupt file can also make it allocate from a garbage size.
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const openvdb::Exception &e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        } catch (const std::bad_alloc &) {
            PyErr_SetString(PyExc_ValueError, "truncated or corrupt file (it asks for an impossible allocation)");
        }
    });
    m.def("save", &save, py::arg("path"), py::arg("name"), py::arg("out_path"),
          "Read one grid and write it in Volpath's brick layout to out_path.");
    m.def("write", &write_vdb, py::arg("brick_path"), py::arg("name"), py::arg("out_path"),
          "Write a brick file as a .vdb file holding one fog-volume grid called name.");
}
