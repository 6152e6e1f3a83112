/*
 * imap.hpp — a C++ wrapper of libimap's C API (imap.h): RAII ownership of contexts,
 * exceptions instead of statuses, vectors instead of pointer + count. Header-only; link
 * imap::imap as for C.
 *
 *     imap::Context ctx(imap::config());          // throws imap::Error on failure
 *     auto mat = imap::material();  double grey = 0.5;
 *     mat.diffuse_reflectance = &grey;  mat.diffuse_reflectance_count = 1;
 *     auto mesh = imap::mesh();  ... ;  uint32_t id = ctx.add_mesh(mesh);
 *     ctx.add_point_light({0, 0, 2}, {100.0});
 *     auto run = imap::run_params();  run.target_rel_error = 0.01;
 *     ctx.run(run, [](const ImapProgress& p) { return p.elapsed_s < 60; });
 *     std::vector<double> e = ctx.irradiance(id, IMAP_SIDE_FRONT, 0);   // W/m²
 *
 * imap::Error carries the status and the library's message (copied when thrown, so it
 * outlives the context). A callback may throw: the run is cancelled and the exception is
 * rethrown from run() or render() once the library has returned.
 */
#ifndef IMAP_HPP
#define IMAP_HPP

#include <imap.h>

#include <array>
#include <cstdint>
#include <exception>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace imap {

/// A failed libimap call: its status and the library's message.
class Error : public std::runtime_error {
public:
    Error(ImapStatus status, const std::string& message)
        : std::runtime_error(std::string(imap_status_name(status)) + ": " + message), status_(status) {}
    ImapStatus status() const noexcept { return status_; }

private:
    ImapStatus status_;
};

/// Throws imap::Error for a status other than IMAP_OK, with the calling thread's message
/// on `ctx` (or its last message when `ctx` is null).
inline void check(ImapStatus status, const ImapContext* ctx = nullptr) {
    if (status != IMAP_OK) throw Error(status, imap_last_error(ctx));
}

/// Initialised structs: the library's defaults, with struct_size set.
inline ImapConfig config() {
    ImapConfig c;
    check(imap_config_default(&c, sizeof c));
    return c;
}
inline ImapMaterial material() {
    ImapMaterial m;
    check(imap_material_default(&m, sizeof m));
    return m;
}
inline ImapMesh mesh() {
    ImapMesh m;
    check(imap_mesh_default(&m, sizeof m));
    return m;
}
inline ImapRunParams run_params() {
    ImapRunParams p;
    check(imap_run_params_default(&p, sizeof p));
    return p;
}
inline ImapRenderParams render_params() {
    ImapRenderParams p;
    check(imap_render_params_default(&p, sizeof p));
    return p;
}
inline ImapCamera camera() {
    ImapCamera c;
    check(imap_camera_default(&c, sizeof c));
    return c;
}
inline ImapLight light() {
    ImapLight l;
    check(imap_light_default(&l, sizeof l));
    return l;
}
inline ImapSpectrum spectrum() {
    ImapSpectrum s;
    check(imap_spectrum_default(&s, sizeof s));
    return s;
}
inline ImapLuminaire luminaire() {
    ImapLuminaire p;
    check(imap_luminaire_default(&p, sizeof p));
    return p;
}
inline ImapPhotometry photometry() {
    ImapPhotometry t;
    check(imap_photometry_default(&t, sizeof t));
    return t;
}

/// Correlated colour temperature (K) and Duv of CIE 1931 tristimulus values.
inline std::array<double, 2> cct(const std::array<double, 3>& xyz) {
    std::array<double, 2> out{};
    check(imap_xyz_to_cct(xyz.data(), &out[0], &out[1]));
    return out;
}

/// A progress callback: return false to stop.
using Progress = std::function<bool(const ImapProgress&)>;

namespace detail {
struct Callback {
    Progress* fn;
    std::exception_ptr error;
};
}  // namespace detail
}  // namespace imap

/* The C-linkage bridge from the library's callback to a Progress (prefixed: C names are
 * global). */
extern "C" inline int32_t imap_hpp_progress_trampoline(const ImapProgress* p, void* user) {
    auto* cb = static_cast<imap::detail::Callback*>(user);
    if (cb->error) return 1; /* it threw already: no more calls */
    try {
        return (*cb->fn)(*p) ? 0 : 1;
    } catch (...) {
        cb->error = std::current_exception();
        return 1;
    }
}

namespace imap {

/// An image rendered by Context::render: radiance per pixel and band, W/(m²·sr).
struct Image {
    uint32_t width = 0, height = 0, bands = 0;
    std::vector<double> radiance;
    std::vector<double> rel_error;
    ImapRenderReport report{};
};

/// An illumination-map context. Not copyable; movable. Like the C handle, one call at a
/// time (a second thread gets imap::Error with IMAP_ERR_BUSY).
class Context {
public:
    explicit Context(const ImapConfig& cfg = config()) { check(imap_create(&cfg, &ctx_)); }
    ~Context() { imap_destroy(ctx_); }
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
    Context(Context&& o) noexcept : ctx_(std::exchange(o.ctx_, nullptr)) {}
    Context& operator=(Context&& o) noexcept {
        if (this != &o) {
            imap_destroy(ctx_);
            ctx_ = std::exchange(o.ctx_, nullptr);
        }
        return *this;
    }

    /// The C handle, for calls this wrapper does not cover.
    ImapContext* get() const noexcept { return ctx_; }

    uint32_t add_material(const ImapMaterial& m) {
        uint32_t id = 0;
        check(imap_add_material(ctx_, &m, &id), ctx_);
        return id;
    }
    uint32_t add_mesh(const ImapMesh& m) {
        uint32_t id = 0;
        check(imap_add_mesh(ctx_, &m, &id), ctx_);
        return id;
    }
    /// An isotropic point light; power in W per band (1 value: grey).
    uint32_t add_point_light(const std::array<double, 3>& position, const std::vector<double>& power) {
        uint32_t id = 0;
        check(imap_add_point_light(ctx_, position.data(), power.data(), power.size(), &id), ctx_);
        return id;
    }
    uint32_t add_spot_light(const std::array<double, 3>& position, const std::array<double, 3>& direction,
                            double half_angle_rad, const std::vector<double>& power) {
        uint32_t id = 0;
        check(imap_add_spot_light(ctx_, position.data(), direction.data(), half_angle_rad, power.data(),
                                  power.size(), &id),
              ctx_);
        return id;
    }

    /// A point, spot, cosine or beam light in any IMAP_UNIT_* (spectrum: EQUAL if null).
    uint32_t add_light(const ImapLight& l, const ImapSpectrum* s = nullptr) {
        uint32_t id = 0;
        check(imap_add_light(ctx_, &l, s, &id), ctx_);
        return id;
    }
    /// A luminaire from the text of an IES LM-63 file (and of the TILT file it names).
    uint32_t add_luminaire_ies(const std::string& text, const ImapLuminaire& place = luminaire(),
                               const ImapSpectrum* s = nullptr, const std::string& tilt = std::string()) {
        uint32_t id = 0;
        check(imap_add_luminaire_ies(ctx_, text.data(), text.size(), tilt.empty() ? nullptr : tilt.data(),
                                     tilt.size(), &place, s, &id),
              ctx_);
        return id;
    }
    /// A luminaire from the text of a EULUMDAT file.
    uint32_t add_luminaire_ldt(const std::string& text, const ImapLuminaire& place = luminaire(),
                               const ImapSpectrum* s = nullptr) {
        uint32_t id = 0;
        check(imap_add_luminaire_ldt(ctx_, text.data(), text.size(), &place, s, &id), ctx_);
        return id;
    }
    /// Luminous flux a light emits, lm.
    double light_lumens(uint32_t id) const {
        double lm = 0;
        check(imap_get_light_flux(ctx_, id, nullptr, 0, &lm), ctx_);
        return lm;
    }
    /// Illuminance in lux at every vertex of `mesh` on `side`.
    std::vector<double> illuminance(uint32_t mesh, uint32_t side) const {
        std::vector<double> e(vertex_count(mesh));
        check(imap_get_vertex_illuminance(ctx_, mesh, side, e.data(), e.size()), ctx_);
        return e;
    }
    /// CIE 1931 X, Y, Z at every vertex (three per vertex).
    std::vector<double> xyz(uint32_t mesh, uint32_t side) const {
        std::vector<double> e(3 * vertex_count(mesh));
        check(imap_get_vertex_xyz(ctx_, mesh, side, e.data(), e.size()), ctx_);
        return e;
    }

    /// Each vertex's area, m² (a third of each adjacent triangle's).
    std::vector<double> vertex_areas(uint32_t mesh) const {
        std::vector<double> a(vertex_count(mesh));
        check(imap_get_vertex_areas(ctx_, mesh, a.data(), a.size()), ctx_);
        return a;
    }

    /// A mesh side's (or its part's) flux, Eavg, Emin, Emax, U0 and Ud with their errors
    /// (docs/results.md).
    ImapRegionStats region_stats(uint32_t mesh, uint32_t side, uint32_t part = IMAP_ALL_PARTS) const {
        ImapRegionStats s;
        check(imap_get_region_stats(ctx_, mesh, side, part, &s, sizeof s), ctx_);
        return s;
    }

    /// `region_stats` of one layer (a light group, IMAP_LAYER_DIRECT or IMAP_LAYER_ALL).
    ImapRegionStats layer_region_stats(uint32_t mesh, uint32_t side, uint32_t layer,
                                       uint32_t part = IMAP_ALL_PARTS) const {
        ImapRegionStats s;
        check(imap_get_layer_region_stats(ctx_, mesh, side, part, layer, &s, sizeof s), ctx_);
        return s;
    }

    /// Light groups and layers (docs/results.md): `flags` of IMAP_KEEP_LIGHT_GROUPS and
    /// IMAP_KEEP_DIRECT; before any run.
    void set_layers(uint32_t flags) { check(imap_set_layers(ctx_, flags), ctx_); }
    void set_light_group(uint32_t light, uint32_t group) { check(imap_set_light_group(ctx_, light, group), ctx_); }
    void set_mesh_light_group(uint32_t mesh, uint32_t group) {
        check(imap_set_mesh_light_group(ctx_, mesh, group), ctx_);
    }
    /// Group layers kept (0: none).
    uint32_t light_group_layers() const {
        uint32_t g = 0;
        check(imap_get_layers(ctx_, &g, nullptr), ctx_);
        return g;
    }
    /// Illuminance in lux of `layer` (a group, IMAP_LAYER_DIRECT or IMAP_LAYER_ALL).
    std::vector<double> layer_illuminance(uint32_t mesh, uint32_t side, uint32_t layer) const {
        std::vector<double> e(vertex_count(mesh));
        check(imap_get_layer_illuminance(ctx_, mesh, side, layer, e.data(), e.size()), ctx_);
        return e;
    }
    std::vector<double> layer_irradiance(uint32_t mesh, uint32_t side, uint32_t band, uint32_t layer) const {
        std::vector<double> e(vertex_count(mesh));
        check(imap_get_layer_energy(ctx_, mesh, side, band, layer, e.data(), e.size()), ctx_);
        return e;
    }
    std::vector<double> layer_rel_error(uint32_t mesh, uint32_t side, uint32_t layer) const {
        std::vector<double> e(vertex_count(mesh));
        check(imap_get_layer_error(ctx_, mesh, side, layer, e.data(), e.size()), ctx_);
        return e;
    }

    /// Runs until a stop criterion of `p` (or `progress` returning false) stops it.
    ImapReport run(ImapRunParams p, Progress progress = nullptr) {
        detail::Callback cb{&progress, nullptr};
        if (progress) p.progress = imap_hpp_progress_trampoline, p.user_data = &cb;
        ImapReport r;
        ImapStatus s = imap_run(ctx_, &p, &r, sizeof r);
        if (cb.error) std::rethrow_exception(cb.error);
        check(s, ctx_);
        return r;
    }
    ImapReport report() const {
        ImapReport r;
        check(imap_get_report(ctx_, &r, sizeof r), ctx_);
        return r;
    }
    std::vector<ImapProgress> history() const {
        size_t n = 0;
        check(imap_get_history(ctx_, nullptr, 0, sizeof(ImapProgress), &n), ctx_);
        std::vector<ImapProgress> h(n);
        check(imap_get_history(ctx_, h.data(), h.size(), sizeof(ImapProgress), &n), ctx_);
        h.resize(n < h.size() ? n : h.size());
        return h;
    }
    size_t vertex_count(uint32_t mesh) const {
        size_t n = 0;
        check(imap_get_vertex_count(ctx_, mesh, &n), ctx_);
        return n;
    }
    /// Irradiance in W/m² of `band` at every vertex of `mesh` on `side`.
    std::vector<double> irradiance(uint32_t mesh, uint32_t side, uint32_t band) const {
        std::vector<double> e(vertex_count(mesh));
        check(imap_get_vertex_energy(ctx_, mesh, side, band, e.data(), e.size()), ctx_);
        return e;
    }
    /// Relative standard error of every vertex's band-mean irradiance.
    std::vector<double> rel_error(uint32_t mesh, uint32_t side) const {
        std::vector<double> e(vertex_count(mesh));
        check(imap_get_vertex_error(ctx_, mesh, side, e.data(), e.size()), ctx_);
        return e;
    }
    double absorbed_w(uint32_t mesh) const {
        double w = 0;
        check(imap_get_mesh_absorbed(ctx_, mesh, &w), ctx_);
        return w;
    }
    void reset() { check(imap_reset(ctx_), ctx_); }

    /// Renders `cam` with `bands` bands per pixel (3 for RGB contexts).
    Image render(const ImapCamera& cam, ImapRenderParams p, uint32_t bands, Progress progress = nullptr) {
        detail::Callback cb{&progress, nullptr};
        if (progress) p.progress = imap_hpp_progress_trampoline, p.user_data = &cb;
        Image img;
        img.width = cam.width, img.height = cam.height, img.bands = bands;
        size_t pixels = static_cast<size_t>(cam.width) * cam.height;
        img.radiance.resize(pixels * bands);
        img.rel_error.resize(pixels);
        ImapStatus s = imap_render(ctx_, &cam, &p, img.radiance.data(), img.radiance.size(), img.rel_error.data(),
                                   img.rel_error.size(), &img.report, sizeof img.report);
        if (cb.error) std::rethrow_exception(cb.error);
        check(s, ctx_);
        return img;
    }

private:
    ImapContext* ctx_ = nullptr;
};

}  // namespace imap

#endif /* IMAP_HPP */
