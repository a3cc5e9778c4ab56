#include "volpath/texture.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace volpath {

Real srgb_to_linear(uint8_t v) {
    static const std::array<Real, 256> table = [] {
        std::array<Real, 256> t{};
        for (int i = 0; i < 256; ++i) {
            const Real c = i / 255.0;
            t[size_t(i)] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
        }
        return t;
    }();
    return table[v];
}

namespace {

// A texel index along an axis of n texels, from a coordinate that may lie anywhere (worked
// in doubles so that no finite coordinate overflows an int).
int wrap_index(Real i, int n, BitmapTexture::Wrap wrap) {
    if (!(std::abs(i) < 1e15)) i = 0;  // NaN or absurdly far: any texel is as good
    switch (wrap) {
        case BitmapTexture::Wrap::Clamp:
            return int(std::clamp(i, Real(0), Real(n - 1)));
        case BitmapTexture::Wrap::Mirror: {
            const Real j = i - 2.0 * n * std::floor(i / (2.0 * n));
            return std::clamp(int(j < n ? j : 2.0 * n - 1 - j), 0, n - 1);
        }
        default:
            return std::clamp(int(i - n * std::floor(i / n)), 0, n - 1);
    }
}

Spectrum eval(const BitmapTexture &t, Vec2 uv) {
    uv = t.to_uv.apply(uv);
    const Real x = uv.x * t.width, y = uv.y * t.height;
    if (!t.bilinear)
        return t.texel(wrap_index(std::floor(x), t.width, t.wrap), wrap_index(std::floor(y), t.height, t.wrap));
    // Texel centres sit at half-integers.
    const Real fx0 = std::floor(x - 0.5), fy0 = std::floor(y - 0.5);
    const Real ax = x - 0.5 - fx0, ay = y - 0.5 - fy0;
    const int x0 = wrap_index(fx0, t.width, t.wrap), x1 = wrap_index(fx0 + 1, t.width, t.wrap);
    const int y0 = wrap_index(fy0, t.height, t.wrap), y1 = wrap_index(fy0 + 1, t.height, t.wrap);
    return (t.texel(x0, y0) * (1 - ax) + t.texel(x1, y0) * ax) * (1 - ay) +
           (t.texel(x0, y1) * (1 - ax) + t.texel(x1, y1) * ax) * ay;
}

Spectrum eval(const CheckerboardTexture &t, Vec2 uv) {
    uv = t.to_uv.apply(uv);
    const bool u_high = uv.x - std::floor(uv.x) > 0.5, v_high = uv.y - std::floor(uv.y) > 0.5;
    return u_high == v_high ? t.color0 : t.color1;
}

}  // namespace

Spectrum BitmapTexture::texel(int x, int y) const {
    const size_t i = (size_t(y) * size_t(width) + size_t(x)) * size_t(channels);
    Spectrum v;
    for (int c = 0; c < 3; ++c) {
        const size_t k = i + size_t(channels == 3 ? c : 0);
        v[c] = floats.empty() ? (srgb ? srgb_to_linear(bytes[k]) : bytes[k] / 255.0) : Real(floats[k]);
    }
    return v;
}

Spectrum eval_texture(const Texture &texture, Vec2 uv) {
    return std::visit([&](const auto &t) { return eval(t, uv); }, texture);
}

Real texture_step(const Texture &texture) {
    if (const auto *b = std::get_if<BitmapTexture>(&texture)) return 0.5 / std::max(b->width, b->height);
    return 1e-3;
}

size_t texture_bytes(const Texture &texture) {
    if (const auto *b = std::get_if<BitmapTexture>(&texture))
        return sizeof(BitmapTexture) + b->bytes.capacity() + b->floats.capacity() * sizeof(float);
    return sizeof(CheckerboardTexture);
}

Real mean_luminance(const Texture &texture) {
    if (const auto *c = std::get_if<CheckerboardTexture>(&texture))
        return (luminance(c->color0) + luminance(c->color1)) / 2;
    const auto &b = std::get<BitmapTexture>(texture);
    Real sum = 0;
    for (int y = 0; y < b.height; ++y)
        for (int x = 0; x < b.width; ++x) sum += luminance(b.texel(x, y));
    return b.width * b.height > 0 ? sum / (Real(b.width) * b.height) : 0.0;
}

}  // namespace volpath
