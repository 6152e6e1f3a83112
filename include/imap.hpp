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
/// An observer: an eye, the direction it looks in and its up (scene units).
inline ImapObserver observer(const std::array<double, 3>& eye, const std::array<double, 3>& view,
                             const std::array<double, 3>& up = {0.0, 0.0, 1.0}) {
    ImapObserver o;
    check(imap_observer_default(&o, sizeof o));
    for (int k = 0; k < 3; ++k) {
        o.eye[k] = eye[k];
        o.view[k] = view[k];
        o.up[k] = up[k];
    }
    return o;
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

inline ImapSky sky() {
    ImapSky s;
    check(imap_sky_default(&s, sizeof s));
    return s;
}
inline ImapSun sun() {
    ImapSun s;
    check(imap_sun_default(&s, sizeof s));
    return s;
}
inline ImapSunTime sun_time() {
    ImapSunTime t;
    check(imap_sun_time_default(&t, sizeof t));
    return t;
}

/// The sun's {azimuth, zenith angle}, degrees, at a place and time (NREL SPA).
inline std::array<double, 2> sun_position(const ImapSunTime& t) {
    std::array<double, 2> out{};
    check(imap_sun_position(&t, &out[0], &out[1]));
    return out;
}

/// An hour's Perez sky (Perez et al. 1990): its clearness and brightness for
/// `ImapSky::perez_clearness`/`perez_brightness`, and the diffuse horizontal and direct
/// normal illuminance for the sky's and the sun's amounts, from the hour's direct normal
/// and diffuse horizontal irradiance (W/m²), the sun's zenith angle (°), the day of the
/// year and the precipitable water (cm; 2 as gendaylit takes it). Throws for an hour
/// without diffuse light (IMAP_ERR_NO_LIGHT).
inline ImapPerezSky perez_sky(double direct_normal, double diffuse_horizontal, double sun_zenith_deg,
                              uint32_t day_of_year, double precipitable_water_cm = 2.0) {
    ImapPerezSky out{};
    check(imap_perez_sky(direct_normal, diffuse_horizontal, sun_zenith_deg, day_of_year, precipitable_water_cm,
                         &out, sizeof out));
    return out;
}

/// CIE 1931 chromaticity {x, y} of tristimulus values.
inline std::array<double, 2> chromaticity(const std::array<double, 3>& xyz) {
    std::array<double, 2> out{};
    check(imap_xyz_chromaticity(xyz.data(), out.data()));
    return out;
}

/// What a saved state holds: its photons and its metadata (copied).
struct StateInfo {
    uint64_t photons = 0;
    std::string meta;
};

/// Reads the header of a state in memory (imap_state_info) without a context.
inline StateInfo state_info(const std::vector<unsigned char>& state) {
    StateInfo info;
    const void* meta = nullptr;
    size_t len = 0;
    check(imap_state_info(state.data(), state.size(), &info.photons, &meta, &len));
    if (meta && len) info.meta.assign(static_cast<const char*>(meta), len);
    return info;
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

/// An observer's light and glare, and every light source it sees (largest UGR term first).
struct Glare {
    ImapGlare figures{};
    std::vector<ImapGlareSource> sources;
};

/// An illumination-map context. Not copyable; movable. Like the C handle, one call at a
/// time (a second thread gets imap::Error with IMAP_ERR_BUSY).
class Context {
public:
    explicit Context(const ImapConfig& cfg = config())
        : bands_(cfg.band_mode == IMAP_BANDS_RGB ? 3u : cfg.band_count) {
        check(imap_create(&cfg, &ctx_));
    }
    ~Context() { imap_destroy(ctx_); }
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
    Context(Context&& o) noexcept : ctx_(std::exchange(o.ctx_, nullptr)), bands_(o.bands_) {}
    Context& operator=(Context&& o) noexcept {
        if (this != &o) {
            imap_destroy(ctx_);
            ctx_ = std::exchange(o.ctx_, nullptr);
            bands_ = o.bands_;
        }
        return *this;
    }

    /// Bands of the map (3 for RGB).
    uint32_t bands() const noexcept { return bands_; }

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
    /// A luminaire from a photometric table of the host's own (imap_add_luminaire_table).
    uint32_t add_luminaire_table(const ImapPhotometry& table, const ImapLuminaire& place = luminaire(),
                                 const ImapSpectrum* s = nullptr) {
        uint32_t id = 0;
        check(imap_add_luminaire_table(ctx_, &table, &place, s, &id), ctx_);
        return id;
    }
    /// For a light or luminaire: the luminous flux it emits, lm. For a sky or the sun it
    /// is NOT a flux: it is the illuminance, lx, the sky or sun gives an unobstructed
    /// horizontal plane (their flux into a scene depends on the scene's size); see
    /// horizontal_illuminance().
    double light_lumens(uint32_t id) const {
        double lm = 0;
        check(imap_get_light_flux(ctx_, id, nullptr, 0, &lm), ctx_);
        return lm;
    }
    /// The illuminance, lx, a sky or the sun gives an unobstructed horizontal plane (the
    /// same call as light_lumens(), named for what it returns for distant lights).
    double horizontal_illuminance(uint32_t sky_or_sun) const { return light_lumens(sky_or_sun); }
    /// Per band: a light's radiant flux, W; a sky's or the sun's horizontal irradiance, W/m².
    std::vector<double> light_band_flux(uint32_t id) const {
        std::vector<double> w(bands_);
        check(imap_get_light_flux(ctx_, id, w.data(), w.size(), nullptr), ctx_);
        return w;
    }

    /// The sensor that measures an observer's vertical illuminance (imap_add_observer_sensor):
    /// its mesh id. Add it before the run.
    uint32_t add_observer_sensor(const ImapObserver& o, double radius) {
        uint32_t id = 0;
        check(imap_add_observer_sensor(ctx_, &o, radius, &id), ctx_);
        return id;
    }
    /// The observer's glare after a run, its Ev and σ read from its sensor `mesh`
    /// (vertex 0, front side).
    Glare observer_glare(const ImapObserver& o, uint32_t mesh) {
        size_t n = 0;
        check(imap_get_vertex_count(ctx_, mesh, &n), ctx_);
        std::vector<double> e(n), r(n);
        check(imap_get_vertex_illuminance(ctx_, mesh, 0, e.data(), e.size()), ctx_);
        check(imap_get_vertex_error(ctx_, mesh, 0, r.data(), r.size()), ctx_);
        return observer_glare(o, e.at(0), e.at(0) * r.at(0));
    }
    /// The observer's glare for a vertical illuminance `ev_lx` ± `ev_sigma_lx` at its eye.
    /// (One call for up to 64 sources in view; a second only for more.)
    Glare observer_glare(const ImapObserver& o, double ev_lx, double ev_sigma_lx) {
        Glare g;
        g.sources.resize(64);
        size_t count = 0;
        check(imap_observer_glare(ctx_, &o, ev_lx, ev_sigma_lx, &g.figures, sizeof g.figures, g.sources.data(),
                                  g.sources.size(), sizeof(ImapGlareSource), &count),
              ctx_);
        if (count > g.sources.size()) {
            g.sources.resize(count);
            check(imap_observer_glare(ctx_, &o, ev_lx, ev_sigma_lx, &g.figures, sizeof g.figures,
                                      g.sources.data(), count, sizeof(ImapGlareSource), &count),
                  ctx_);
        }
        g.sources.resize(count);
        return g;
    }

    /// A sky or environment (imap_add_sky; an IMAP_SKY_IMAGE's pixels in sky.image_rgb).
    uint32_t add_sky(const ImapSky& sky, const ImapSpectrum* s = nullptr) {
        uint32_t id = 0;
        check(imap_add_sky(ctx_, &sky, s, &id), ctx_);
        return id;
    }
    /// An environment image from a Radiance HDR (.hdr/.pic) or OpenEXR file; `sky` gives
    /// its unit, amount, zenith, north and rotation.
    uint32_t add_sky_file(const std::string& path, const ImapSky& sky_settings = sky()) {
        uint32_t id = 0;
        check(imap_add_sky_file(ctx_, path.c_str(), &sky_settings, &id), ctx_);
        return id;
    }
    /// The sun (a distant light of the sun's solid angle).
    uint32_t add_sun(const ImapSun& sun, const ImapSpectrum* s = nullptr) {
        uint32_t id = 0;
        check(imap_add_sun(ctx_, &sun, s, &id), ctx_);
        return id;
    }
    /// The ground's glow below the horizon of `zenith`: ρ E_h / π of the skies and suns
    /// added before it (`reflectance`: one grey value or one per band).
    uint32_t add_ground(const std::vector<double>& reflectance,
                        const std::array<double, 3>& zenith = {0.0, 0.0, 1.0}) {
        uint32_t id = 0;
        check(imap_add_ground(ctx_, reflectance.data(), reflectance.size(), zenith.data(), &id),
              ctx_);
        return id;
    }
    /// Window portals (triangles facing out of the model): distant light enters only
    /// through them. Empty vectors remove them.
    void set_portals(const std::vector<double>& positions, const std::vector<uint32_t>& indices) {
        check(imap_set_portals(ctx_, positions.data(), positions.size() / 3, indices.data(),
                               indices.size() / 3),
              ctx_);
    }
    /// The medium of `material` (an index-1 dielectric that absorbs or scatters) fills the
    /// space outside the meshes (haze, fog); IMAP_NO_MEDIUM empties it
    /// (imap_set_scene_medium). What it absorbed: medium_absorbed(IMAP_SCENE_MEDIUM).
    void set_scene_medium(uint32_t material) { check(imap_set_scene_medium(ctx_, material), ctx_); }
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
    /// A region's radiant flux per band with its standard error: {flux, sigma} per band, W.
    std::vector<std::array<double, 2>> region_band_flux(uint32_t mesh, uint32_t side,
                                                        uint32_t part = IMAP_ALL_PARTS) const {
        std::vector<std::array<double, 2>> out(bands_);
        check(imap_get_region_band_flux(ctx_, mesh, side, part, out.empty() ? nullptr : out[0].data(),
                                        2 * out.size()),
              ctx_);
        return out;
    }
    /// Luminous efficacy of each band, lm/W.
    std::vector<double> band_efficacy() const {
        std::vector<double> k(bands_);
        check(imap_get_band_efficacy(ctx_, k.data(), k.size()), ctx_);
        return k;
    }
    /// The power balance per band, W: `kind` IMAP_BALANCE_EMITTED, _ABSORBED, _ESCAPED or
    /// _DROPPED.
    std::vector<double> band_balance(uint32_t kind) const {
        std::vector<double> w(bands_);
        check(imap_get_band_balance(ctx_, kind, w.data(), w.size()), ctx_);
        return w;
    }
    /// Triangles of `mesh` left out as degenerate.
    size_t dropped_triangles(uint32_t mesh) const {
        size_t n = 0;
        check(imap_get_mesh_dropped_triangles(ctx_, mesh, &n), ctx_);
        return n;
    }
    double absorbed_w(uint32_t mesh) const {
        double w = 0;
        check(imap_get_mesh_absorbed(ctx_, mesh, &w), ctx_);
        return w;
    }
    /// What the medium inside `mesh` absorbed: {W, sigma} per band, then {lm, sigma} last
    /// (imap_get_medium_absorbed).
    std::vector<std::array<double, 2>> medium_absorbed(uint32_t mesh) const {
        std::vector<std::array<double, 2>> out(bands_ + 1);
        check(imap_get_medium_absorbed(ctx_, mesh, out[0].data(), 2 * out.size()), ctx_);
        return out;
    }
    void reset() { check(imap_reset(ctx_), ctx_); }

    /// The state (map, counters, history, `meta`) as bytes (imap_state_write; `flags`
    /// IMAP_STATE_NO_MAP leaves the map out).
    std::vector<unsigned char> state(const std::string& meta = std::string(), uint32_t flags = 0) {
        size_t need = 0;
        ImapStatus s = imap_state_write(ctx_, flags, meta.data(), meta.size(), nullptr, 0, &need);
        if (s != IMAP_ERR_BUFFER_TOO_SMALL) check(s, ctx_);
        std::vector<unsigned char> buf(need);
        check(imap_state_write(ctx_, flags, meta.data(), meta.size(), buf.data(), buf.size(), &need), ctx_);
        buf.resize(need);
        return buf;
    }
    /// Writes the state to `path` (a checkpoint; replaced atomically).
    void save_state(const std::string& path, const std::string& meta = std::string()) {
        check(imap_state_save(ctx_, path.c_str(), meta.data(), meta.size()), ctx_);
    }
    /// Replaces the map with a saved state of the same scene (resume).
    void load_state(const std::vector<unsigned char>& state) {
        check(imap_state_load(ctx_, state.data(), state.size()), ctx_);
    }
    void load_state_file(const std::string& path) { check(imap_state_load_file(ctx_, path.c_str()), ctx_); }
    /// Adds another run's state of the same scene (shards).
    void merge_state(const std::vector<unsigned char>& state) {
        check(imap_state_merge(ctx_, state.data(), state.size()), ctx_);
    }
    void merge_state_file(const std::string& path) { check(imap_state_merge_file(ctx_, path.c_str()), ctx_); }

    /// The report and the error history of the last render.
    ImapRenderReport render_report() const {
        ImapRenderReport r;
        check(imap_get_render_report(ctx_, &r, sizeof r), ctx_);
        return r;
    }
    std::vector<ImapProgress> render_history() const {
        size_t n = 0;
        check(imap_get_render_history(ctx_, nullptr, 0, sizeof(ImapProgress), &n), ctx_);
        std::vector<ImapProgress> h(n);
        check(imap_get_render_history(ctx_, h.data(), h.size(), sizeof(ImapProgress), &n), ctx_);
        h.resize(n < h.size() ? n : h.size());
        return h;
    }

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
    uint32_t bands_ = 3;
};

/* Annual daylight (docs/daylight.md, "Annual daylight"): sky vectors from a weather file,
 * daylight coefficients, the direct sun on its lines, hourly illuminance and metrics. */

/// Daylight coefficients at points: `value` and `sigma` hold points × patches, point by
/// point, the ground's first (lx per cd/m², with standard errors).
struct Coefficients {
    size_t points = 0, patches = 0;
    std::vector<double> value, sigma;
    uint64_t photons = 0;
};

/// A year (or any run of hours) of sky vectors read from an EPW or .wea file. Not
/// copyable; movable.
class AnnualSky {
public:
    /// Reads `path` over Reinhart MF:`mf` patches, the ground glowing at `ground_reflectance`.
    AnnualSky(const std::string& path, uint32_t mf, double ground_reflectance = 0.2) {
        check(imap_annual_sky_read(path.c_str(), mf, ground_reflectance, &sky_));
        check(imap_annual_sky_size(sky_, &hours_, &patches_));
    }
    ~AnnualSky() { imap_annual_sky_free(sky_); }
    AnnualSky(const AnnualSky&) = delete;
    AnnualSky& operator=(const AnnualSky&) = delete;
    AnnualSky(AnnualSky&& o) noexcept
        : sky_(std::exchange(o.sky_, nullptr)), hours_(o.hours_), patches_(o.patches_) {}
    AnnualSky& operator=(AnnualSky&& o) noexcept {
        if (this != &o) {
            imap_annual_sky_free(sky_);
            sky_ = std::exchange(o.sky_, nullptr);
            hours_ = o.hours_, patches_ = o.patches_;
        }
        return *this;
    }
    size_t hours() const noexcept { return hours_; }
    /// Patches per vector, the ground's included.
    size_t patches() const noexcept { return patches_; }
    ImapAnnualHour hour(size_t h) const {
        ImapAnnualHour a;
        check(imap_annual_sky_hour(sky_, h, &a, sizeof a));
        return a;
    }
    /// Hour `h`'s patch luminances, cd/m².
    std::vector<double> vector(size_t h) const {
        std::vector<double> v(patches_);
        check(imap_annual_sky_vector(sky_, h, v.data(), v.size()));
        return v;
    }
    const ImapAnnualSky* get() const noexcept { return sky_; }

private:
    ImapAnnualSky* sky_ = nullptr;
    size_t hours_ = 0, patches_ = 0;
};

/// Traces the coefficients of MF:`mf` at `vertices` of mesh `mesh` (imap_annual_trace_coefficients:
/// any subdivision, in batches of light groups; the context is left as it was).
inline Coefficients trace_coefficients(Context& ctx, uint32_t mf, uint32_t mesh, uint32_t side,
                                       const std::vector<uint32_t>& vertices, uint64_t photons,
                                       double time_s = 0, uint32_t estimator = IMAP_ESTIMATOR_DEFAULT,
                                       const std::array<double, 3>& zenith = {0, 0, 1},
                                       const std::array<double, 3>& north = {0, 1, 0}) {
    // The patch count of MF:n: 144 n² + 1 (the ground first).
    Coefficients c;
    c.points = vertices.size();
    c.patches = 144u * mf * mf + 2u;
    if (mf == 0 || mf > 16) c.patches = 1; /* the library names the bad mf */
    c.value.resize(c.points * c.patches);
    c.sigma.resize(c.points * c.patches);
    check(imap_annual_trace_coefficients(ctx.get(), mf, zenith.data(), north.data(), photons, time_s, estimator,
                                         mesh, side, vertices.data(), vertices.size(), c.value.data(),
                                         c.sigma.data(), &c.photons),
          ctx.get());
    return c;
}

/// The sun's direct light on its true line each hour at points (x, y, z each) whose
/// measuring sides face `normals`. Not copyable; movable.
class DirectSun {
public:
    DirectSun(Context& ctx, const AnnualSky& sky, const std::vector<double>& points, const std::vector<double>& normals,
              uint64_t seed = 1, const std::array<double, 3>& zenith = {0, 0, 1},
              const std::array<double, 3>& north = {0, 1, 0})
        : points_(points.size() / 3) {
        if (normals.size() != points.size() || points.size() % 3 != 0)
            throw Error(IMAP_ERR_INVALID_ARGUMENT, "points and normals must hold 3 doubles per point each");
        check(imap_direct_sun_new(ctx.get(), sky.get(), points.data(), normals.data(), points_, zenith.data(),
                                  north.data(), seed, &sun_),
              ctx.get());
    }
    ~DirectSun() { imap_direct_sun_free(sun_); }
    DirectSun(const DirectSun&) = delete;
    DirectSun& operator=(const DirectSun&) = delete;
    DirectSun(DirectSun&& o) noexcept : sun_(std::exchange(o.sun_, nullptr)), points_(o.points_) {}
    DirectSun& operator=(DirectSun&& o) noexcept {
        if (this != &o) {
            imap_direct_sun_free(sun_);
            sun_ = std::exchange(o.sun_, nullptr);
            points_ = o.points_;
        }
        return *this;
    }
    /// Hour `h`'s direct illuminance at every point, lx.
    std::vector<double> hour(size_t h) const {
        std::vector<double> e(points_);
        check(imap_direct_sun_hour(sun_, h, e.data(), e.size()));
        return e;
    }
    const ImapDirectSun* get() const noexcept { return sun_; }

private:
    ImapDirectSun* sun_ = nullptr;
    size_t points_ = 0;
};

/// Illuminance and its standard error, hour by hour then point by point.
struct Hourly {
    std::vector<double> value, sigma;
};

/// Hours [`first`, `first` + `hours`) at every point (`sun`: null for sky vectors that hold
/// the sun).
inline Hourly annual_hourly(const AnnualSky& sky, const Coefficients& c, const DirectSun* sun, size_t first,
                            size_t hours) {
    Hourly h;
    h.value.resize(hours * c.points);
    h.sigma.resize(hours * c.points);
    check(imap_annual_hourly(sky.get(), c.value.data(), c.sigma.data(), c.points, sun ? sun->get() : nullptr, first,
                             hours, h.value.data(), h.sigma.data()));
    return h;
}

inline ImapAnnualOptions annual_options() {
    ImapAnnualOptions o;
    check(imap_annual_options_default(&o, sizeof o));
    return o;
}

/// The metrics of a grid and of each point.
struct AnnualMetrics {
    ImapAnnualMetrics grid{};
    std::vector<ImapSensorMetrics> points;
};

inline AnnualMetrics annual_metrics(const AnnualSky& sky, const Coefficients& c, const DirectSun* sun,
                                    const ImapAnnualOptions& options = annual_options()) {
    AnnualMetrics m;
    m.points.resize(c.points);
    check(imap_annual_metrics(sky.get(), c.value.data(), c.sigma.data(), c.points, sun ? sun->get() : nullptr,
                              &options, &m.grid, sizeof m.grid, m.points.data(), sizeof(ImapSensorMetrics)));
    return m;
}

/// A window group (docs/daylight.md, "Window groups"): its states' coefficients, most open
/// first, each traced with the group in that state and every other group's openings black;
/// their direct sun (empty, or one per state: null where a state lets none through); the
/// rule that picks a state each hour (IMAP_SHADING_*, with `rule_lx`, `schedule` or
/// `rule_dgp`). `annual_metrics` fills `state_hours`: the occupied hours spent in each state.
struct WindowGroup {
    std::vector<const Coefficients*> states;
    std::vector<const DirectSun*> suns;
    uint32_t rule = IMAP_SHADING_DIRECT_SUN;
    double rule_lx = 0;
    std::vector<uint16_t> schedule;
    std::vector<uint64_t> state_hours;
    double rule_dgp = 0.40;
};

namespace detail {
/// The C structs of `groups` (kept alive with it) and the points they hold.
struct GroupStructs {
    std::vector<std::vector<const double*>> values, sigmas;
    std::vector<std::vector<const ImapDirectSun*>> suns;
    std::vector<ImapWindowGroup> structs;
    std::vector<const ImapWindowGroup*> pointers;
    const Coefficients* first = nullptr;

    GroupStructs(const Coefficients* base, std::vector<WindowGroup>& groups, const char* what)
        : values(groups.size()), sigmas(groups.size()), suns(groups.size()), structs(groups.size()),
          pointers(groups.size()), first(base) {
        for (const auto& g : groups)
            if (!first && !g.states.empty()) first = g.states.front();
        if (!first) throw Error(IMAP_ERR_INVALID_ARGUMENT, std::string(what) + ": no base and no window group state");
        for (size_t i = 0; i < groups.size(); i++) {
            WindowGroup& g = groups[i];
            if (!g.suns.empty() && g.suns.size() != g.states.size())
                throw Error(IMAP_ERR_INVALID_ARGUMENT, std::string(what) + ": a window group's suns are not one per state");
            for (const Coefficients* c : g.states) {
                if (!c || c->points != first->points)
                    throw Error(IMAP_ERR_INVALID_ARGUMENT, std::string(what) + ": a window group's state has other points");
                values[i].push_back(c->value.data());
                sigmas[i].push_back(c->sigma.data());
            }
            for (const DirectSun* d : g.suns) suns[i].push_back(d ? d->get() : nullptr);
            g.state_hours.assign(g.states.size(), 0);
            check(imap_window_group_default(&structs[i], sizeof structs[i]));
            structs[i].rule = g.rule;
            structs[i].state_count = g.states.size();
            structs[i].value = values[i].data();
            structs[i].sigma = sigmas[i].data();
            structs[i].sun = suns[i].empty() ? nullptr : suns[i].data();
            structs[i].rule_lx = g.rule_lx;
            structs[i].schedule = g.schedule.empty() ? nullptr : g.schedule.data();
            structs[i].schedule_count = g.schedule.size();
            structs[i].state_hours = g.state_hours.data();
            structs[i].rule_dgp = g.rule_dgp;
            pointers[i] = &structs[i];
        }
    }

    ImapAnnualOptions attach(ImapAnnualOptions options) const {
        options.window_groups = pointers.data();
        options.window_group_count = pointers.size();
        return options;
    }
};
}  // namespace detail

/// The metrics of a grid whose light is `base`'s (the light through no window group;
/// null: none) and each of `groups` in the state its rule picks every hour.
inline AnnualMetrics annual_metrics(const AnnualSky& sky, const Coefficients* base, const DirectSun* base_sun,
                                    std::vector<WindowGroup>& groups,
                                    ImapAnnualOptions options = annual_options()) {
    detail::GroupStructs g(base, groups, "annual_metrics");
    options = g.attach(options);
    AnnualMetrics m;
    m.points.resize(g.first->points);
    check(imap_annual_metrics(sky.get(), base ? base->value.data() : nullptr, base ? base->sigma.data() : nullptr,
                              g.first->points, base_sun ? base_sun->get() : nullptr, &options, &m.grid, sizeof m.grid,
                              m.points.data(), sizeof(ImapSensorMetrics)));
    return m;
}

/// Annual glare, imageless (docs/daylight.md, "Observers and annual glare"): per observer
/// whose coefficients `c` are (its sensor faces its view), the shares of the occupied hours
/// with DGPs at or above 0.35, 0.40 and 0.45 with their confidence.
inline std::vector<ImapObserverYear> annual_glare(const AnnualSky& sky, const Coefficients& c, const DirectSun* sun,
                                                  const ImapAnnualOptions& options = annual_options()) {
    std::vector<ImapObserverYear> out(c.points);
    check(imap_annual_glare(sky.get(), c.value.data(), c.sigma.data(), c.points, sun ? sun->get() : nullptr, &options,
                            out.data(), sizeof(ImapObserverYear)));
    return out;
}

/// `annual_glare` of observers whose light is `base`'s and each of `groups` in the state
/// its rule picks every hour.
inline std::vector<ImapObserverYear> annual_glare(const AnnualSky& sky, const Coefficients* base,
                                                  const DirectSun* base_sun, std::vector<WindowGroup>& groups,
                                                  ImapAnnualOptions options = annual_options()) {
    detail::GroupStructs g(base, groups, "annual_glare");
    options = g.attach(options);
    std::vector<ImapObserverYear> out(g.first->points);
    check(imap_annual_glare(sky.get(), base ? base->value.data() : nullptr, base ? base->sigma.data() : nullptr,
                            g.first->points, base_sun ? base_sun->get() : nullptr, &options, out.data(),
                            sizeof(ImapObserverYear)));
    return out;
}

/// Each window group's state every hour as the rules pick them on these sensors (a glare
/// rule at observers), group by group: to give other sensors as IMAP_SHADING_SCHEDULE.
inline std::vector<std::vector<uint16_t>> annual_states(const AnnualSky& sky, const Coefficients* base,
                                                        const DirectSun* base_sun, std::vector<WindowGroup>& groups,
                                                        ImapAnnualOptions options = annual_options()) {
    detail::GroupStructs g(base, groups, "annual_states");
    options = g.attach(options);
    size_t hours = 0, patches = 0;
    check(imap_annual_sky_size(sky.get(), &hours, &patches));
    std::vector<uint16_t> flat(groups.size() * hours);
    check(imap_annual_states(sky.get(), base ? base->value.data() : nullptr, base ? base->sigma.data() : nullptr,
                             g.first->points, base_sun ? base_sun->get() : nullptr, &options, flat.data(), flat.size()));
    std::vector<std::vector<uint16_t>> out(groups.size());
    for (size_t i = 0; i < groups.size(); i++) out[i].assign(flat.begin() + i * hours, flat.begin() + (i + 1) * hours);
    return out;
}

inline ImapDimming dimming() {
    ImapDimming d;
    check(imap_dimming_default(&d, sizeof d));
    return d;
}

/// A zone's annual electric lighting, and per point the share of occupied hours in which
/// daylight and the dimmed light reach the target.
struct AnnualLighting {
    ImapLighting zone{};
    std::vector<double> at_target;
};

/// Electric light with daylight: the zone's lights give `electric` (lx at full output, and
/// its standard error, per point) and are dimmed by `dimming` at its photosensor.
inline AnnualLighting annual_lighting(const AnnualSky& sky, const Coefficients& c, const DirectSun* sun,
                                      const Hourly& electric, const ImapDimming& dimming,
                                      const ImapAnnualOptions& options = annual_options()) {
    if (electric.value.size() != c.points || electric.sigma.size() != c.points)
        throw Error(IMAP_ERR_INVALID_ARGUMENT, "annual_lighting: electric holds other than one value per point");
    AnnualLighting l;
    l.at_target.resize(c.points);
    check(imap_annual_lighting(sky.get(), c.value.data(), c.sigma.data(), c.points, sun ? sun->get() : nullptr,
                               &options, electric.value.data(), electric.sigma.data(), &dimming, &l.zone,
                               sizeof l.zone, l.at_target.data()));
    return l;
}

/// Each point's daylight factor (0–1) under the CIE overcast sky, with its standard error.
inline Hourly daylight_factor(const Coefficients& c, uint32_t mf, double ground_reflectance = 0.2) {
    Hourly d;
    d.value.resize(c.points);
    d.sigma.resize(c.points);
    check(imap_daylight_factor(c.value.data(), c.sigma.data(), c.points, mf, ground_reflectance, d.value.data(),
                               d.sigma.data()));
    return d;
}

}  // namespace imap

#endif /* IMAP_HPP */
