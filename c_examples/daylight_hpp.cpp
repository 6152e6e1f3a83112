// The C++ wrapper beyond the core: skies, the sun, sun positions, layers, states and
// renders through imap.hpp. A 4 × 4 m grey plate under an open sky, unobstructed: its
// average illuminance is the sky's (and the sun's) horizontal illuminance, which
// horizontal_illuminance() reports; a CIE sky of type 12 without its sun is refused as the
// command refuses it; a state written, read back and merged keeps the map (and is not merged twice); a render sees the
// sky's radiance above the horizon; a plate facing down over a ground of reflectance 0.2 reads 0.2 E_h.
#include <imap.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

static int failures = 0;
static const double kPi = 3.14159265358979323846;
#define CHECK(cond, ...)                          \
    do {                                          \
        if (!(cond)) {                            \
            std::printf("FAIL " __VA_ARGS__);     \
            std::printf("\n");                    \
            failures++;                           \
        }                                         \
    } while (0)

// A grey plate [-2, 2]² at z = 0 facing +z (n × n cells), recorded with tallies.
static uint32_t plate(imap::Context& ctx, std::vector<double>& xyz, std::vector<uint32_t>& idx,
                      bool down = false) {
    const int n = 8;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) xyz.insert(xyz.end(), {-2.0 + 4.0 * i / n, -2.0 + 4.0 * j / n, 0.0});
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
            if (down)
                idx.insert(idx.end(), {a, c, b, a, d, c});
            else
                idx.insert(idx.end(), {a, b, c, a, c, d});
        }
    static const double rho = 0.2;
    ImapMaterial grey = imap::material();
    grey.diffuse_reflectance = &rho;
    grey.diffuse_reflectance_count = 1;
    ImapMesh m = imap::mesh();
    m.positions = xyz.data(), m.vertex_count = xyz.size() / 3;
    m.indices = idx.data(), m.triangle_count = idx.size() / 3;
    m.material = ctx.add_material(grey);
    m.flags = IMAP_MESH_RECORD | IMAP_MESH_TALLY;
    return ctx.add_mesh(m);
}

int main() {
    try {
        ImapConfig cfg = imap::config();
        cfg.threads = 2;
        cfg.seed = 5;
        std::vector<double> xyz;
        std::vector<uint32_t> idx;

        // 1. A uniform sky of 10 000 lx on the horizontal.
        imap::Context ctx(cfg);
        uint32_t id = plate(ctx, xyz, idx);
        ImapSky sky = imap::sky();
        sky.unit = IMAP_SKY_UNIT_HORIZONTAL_LX, sky.amount = 10000;
        uint32_t sid = ctx.add_sky(sky);
        double h = ctx.horizontal_illuminance(sid);
        CHECK(std::fabs(h - 10000) < 1e-6, "the sky's horizontal illuminance reads %g lx", h);
        std::vector<double> hw = ctx.light_band_flux(sid);
        std::vector<double> k = ctx.band_efficacy();
        double lm = 0;
        for (size_t b = 0; b < hw.size(); b++) lm += hw[b] * k[b];
        CHECK(hw.size() == 3 && std::fabs(lm - 10000) < 1e-6, "band irradiances give %g lx", lm);
        ctx.set_layers(IMAP_KEEP_DIRECT);
        ImapRunParams run = imap::run_params();
        run.photons = 200000;
        ImapReport r = ctx.run(run);
        ImapRegionStats s = ctx.region_stats(id, IMAP_SIDE_FRONT);
        std::printf("plate under a 10 000 lx sky: Eavg %.1f ± %.1f lx (exact errors %u)\n", s.average_lx,
                    s.average_lx_sigma, s.errors_exact);
        CHECK(s.errors_exact == 1 && std::fabs(s.average_lx - 10000) < 4 * s.average_lx_sigma, "Eavg %g ± %g",
              s.average_lx, s.average_lx_sigma);
        ImapRegionStats d = ctx.layer_region_stats(id, IMAP_SIDE_FRONT, IMAP_LAYER_DIRECT);
        CHECK(std::fabs(d.average_lx - s.average_lx) < 1e-9 * s.average_lx, "all of it is direct: %g vs %g",
              d.average_lx, s.average_lx);
        std::vector<std::array<double, 2>> bf = ctx.region_band_flux(id, IMAP_SIDE_FRONT);
        double flux_lm = 0;
        for (size_t b = 0; b < bf.size(); b++) flux_lm += bf[b][0] * k[b];
        CHECK(std::fabs(flux_lm - s.flux_lm) < 1e-9 * s.flux_lm, "band fluxes %g lm vs %g lm", flux_lm, s.flux_lm);
        std::vector<double> emitted = ctx.band_balance(IMAP_BALANCE_EMITTED);
        CHECK(std::fabs(emitted[0] + emitted[1] + emitted[2] - r.emitted_w) < 1e-9 * r.emitted_w, "balance");

        // 2. States: written with metadata, read back into a context of the same scene
        // (the same map), merged (twice the photons).
        std::vector<unsigned char> state = ctx.state("job 1");
        imap::StateInfo info = imap::state_info(state);
        CHECK(info.photons == r.photons && info.meta == "job 1", "state info: %llu photons, meta '%s'",
              static_cast<unsigned long long>(info.photons), info.meta.c_str());
        imap::Context copy(cfg);
        std::vector<double> xyz2;
        std::vector<uint32_t> idx2;
        uint32_t id2 = plate(copy, xyz2, idx2);
        copy.add_sky(sky);
        copy.set_layers(IMAP_KEEP_DIRECT);
        copy.load_state(state);
        CHECK(copy.illuminance(id2, IMAP_SIDE_FRONT) == ctx.illuminance(id, IMAP_SIDE_FRONT), "loaded map differs");
        // Merged into an emptied map (a shard's result collected): the same photons; merged
        // again, refused (it would count them twice).
        copy.reset();
        copy.merge_state(state);
        CHECK(copy.report().photons == r.photons, "merged: %llu photons",
              static_cast<unsigned long long>(copy.report().photons));
        try {
            copy.merge_state(state);
            CHECK(false, "the same photons were merged twice");
        } catch (const imap::Error& e) {
            CHECK(e.status() == IMAP_ERR_STATE_OVERLAP, "merged twice: %s", e.what());
        }

        // 3. A render from 1.5 m up looking north, slightly down: the upper rows see the
        // sky, whose radiance is its horizontal irradiance / π.
        ImapCamera cam = imap::camera();
        cam.width = 32, cam.height = 24, cam.fov_y_deg = 40;
        cam.position[0] = 0, cam.position[1] = -1.5, cam.position[2] = 1.5;
        cam.direction[0] = 0, cam.direction[1] = 1, cam.direction[2] = -0.2;
        cam.up[0] = 0, cam.up[1] = 0, cam.up[2] = 1;
        ImapRenderParams rp = imap::render_params();
        rp.passes = 2;
        imap::Image img = ctx.render(cam, rp, ctx.bands());
        double top = img.radiance[0], want = hw[0] / kPi;
        std::printf("render: %u passes; sky radiance %.3f W/(m² sr) per band, expected %.3f\n",
                    static_cast<unsigned>(ctx.render_report().passes), top, want);
        CHECK(std::fabs(top / want - 1) < 1e-6, "sky pixel %g vs %g", top, want);
        CHECK(ctx.render_report().passes >= 2 && !ctx.render_history().empty(), "render report and history");

        // 4. A CIE sky of type 12 needs its sun (refused without it, as by the command);
        // with the sun of a June noon in Munich and the sun itself.
        imap::Context day(cfg);
        std::vector<double> xyz3;
        std::vector<uint32_t> idx3;
        uint32_t id3 = plate(day, xyz3, idx3);
        ImapSky cie = imap::sky();
        cie.kind = IMAP_SKY_CIE, cie.cie_type = 12, cie.unit = IMAP_SKY_UNIT_HORIZONTAL_LX, cie.amount = 15000;
        try {
            day.add_sky(cie);
            CHECK(false, "a CIE sky of type 12 without its sun was accepted");
        } catch (const imap::Error& e) {
            std::printf("expected error: %s\n", e.what());
            CHECK(e.status() == IMAP_ERR_INVALID_ARGUMENT && std::string(e.what()).find("needs its sun") != std::string::npos,
                  "wrong error");
        }
        ImapSunTime t = imap::sun_time();
        t.year = 2026, t.month = 6, t.day = 21, t.hour = 13, t.minute = 30, t.utc_offset_hours = 2;
        t.latitude_deg = 48.14, t.longitude_deg = 11.58, t.elevation_m = 520;
        std::array<double, 2> at = imap::sun_position(t);
        std::printf("sun over Munich: azimuth %.2f°, zenith %.2f°\n", at[0], at[1]);
        CHECK(at[0] > 150 && at[0] < 210 && at[1] > 24 && at[1] < 28, "sun position");
        cie.sun_azimuth_deg = at[0], cie.sun_zenith_deg = at[1];
        uint32_t cid = day.add_sky(cie);
        ImapSun sun = imap::sun();
        sun.amount = 80000, sun.azimuth_deg = at[0], sun.zenith_deg = at[1];
        uint32_t sunid = day.add_sun(sun);
        double sun_h = day.horizontal_illuminance(sunid), sky_h = day.horizontal_illuminance(cid);
        CHECK(std::fabs(sun_h - 80000 * std::cos(at[1] * kPi / 180)) < 1e-6 * sun_h, "sun on the horizontal %g", sun_h);
        day.run(run);
        ImapRegionStats ds = day.region_stats(id3, IMAP_SIDE_FRONT);
        std::printf("plate under the CIE 12 sky and the sun: Eavg %.0f ± %.0f lx, expected %.0f\n", ds.average_lx,
                    ds.average_lx_sigma, sun_h + sky_h);
        CHECK(std::fabs(ds.average_lx - sun_h - sky_h) < 4 * ds.average_lx_sigma, "Eavg %g", ds.average_lx);

        // The same noon as an hour of weather: a Perez sky of 600 W/m² direct normal and
        // 150 W/m² diffuse horizontal irradiance, given its diffuse illuminance (ε 4.69 at
        // the sun's 25.9°: bin 6, 4.5–6.2).
        ImapPerezSky hour = imap::perez_sky(600, 150, at[1], 172);
        std::printf("Perez sky: clearness %.3f (bin %u), brightness %.4f, %.0f lx diffuse, %.0f lx direct\n",
                    hour.clearness, hour.bin, hour.brightness, hour.diffuse_horizontal_lx, hour.direct_normal_lx);
        CHECK(hour.bin == 6 && hour.diffuse_horizontal_lx > 15000 && hour.direct_normal_lx > 50000, "Perez hour");
        imap::Context weather(cfg);
        ImapSky perez = imap::sky();
        perez.kind = IMAP_SKY_PEREZ, perez.unit = IMAP_SKY_UNIT_HORIZONTAL_LX, perez.amount = hour.diffuse_horizontal_lx;
        perez.sun_azimuth_deg = at[0], perez.sun_zenith_deg = at[1];
        perez.perez_clearness = hour.clearness, perez.perez_brightness = hour.brightness;
        uint32_t pid = weather.add_sky(perez);
        CHECK(std::fabs(weather.horizontal_illuminance(pid) / hour.diffuse_horizontal_lx - 1) < 1e-9, "Perez amount");
        try {
            imap::perez_sky(600, 0, at[1], 172);
            CHECK(false, "an hour without diffuse light made a sky");
        } catch (const imap::Error& e) {
            CHECK(e.status() == IMAP_ERR_NO_LIGHT, "wrong error for an hour without diffuse light");
        }

        // 4. The ground's glow: a plate facing down under a 10 000 lx sky and a ground of
        // reflectance 0.2 reads 0.2 × 10 000 lx.
        imap::Context under(cfg);
        std::vector<double> xyz4;
        std::vector<uint32_t> idx4;
        uint32_t id4 = plate(under, xyz4, idx4, true);
        try {
            under.add_ground({0.2});
            CHECK(false, "a ground without a sky was accepted");
        } catch (const imap::Error& e) {
            std::printf("expected error: %s\n", e.what());
        }
        under.add_sky(sky);
        uint32_t gid = under.add_ground({0.2});
        CHECK(under.horizontal_illuminance(gid) == 0.0, "the ground gives the horizontal nothing from above");
        under.run(run);
        ImapRegionStats gs = under.region_stats(id4, IMAP_SIDE_FRONT);
        std::printf("plate facing down over a ground of 0.2 under 10 000 lx: Eavg %.1f ± %.1f lx, expected 2000\n",
                    gs.average_lx, gs.average_lx_sigma);
        CHECK(std::fabs(gs.average_lx - 2000) < 4 * gs.average_lx_sigma && gs.average_lx_sigma < 40, "Eavg %g",
              gs.average_lx);

        // 5. A window portal over the plate (its own square, facing up): the sky comes in
        // through it only, and the plate still reads 10 000 lx.
        imap::Context portal(cfg);
        std::vector<double> xyz5;
        std::vector<uint32_t> idx5;
        uint32_t id5 = plate(portal, xyz5, idx5);
        portal.add_sky(sky);
        portal.set_portals({-2, -2, 0, 2, -2, 0, 2, 2, 0, -2, 2, 0}, {0, 1, 2, 0, 2, 3});
        try {
            portal.set_portals({0, 0, 0}, {0, 1, 2});
            CHECK(false, "a portal with an index out of range was accepted");
        } catch (const imap::Error& e) {
            std::printf("expected error: %s\n", e.what());
        }
        portal.run(run);
        ImapRegionStats ps = portal.region_stats(id5, IMAP_SIDE_FRONT);
        std::printf("plate under a 10 000 lx sky through a portal: Eavg %.1f ± %.1f lx\n", ps.average_lx,
                    ps.average_lx_sigma);
        CHECK(std::fabs(ps.average_lx - 10000) < 4 * ps.average_lx_sigma, "Eavg %g", ps.average_lx);
    } catch (const std::exception& e) {
        std::printf("FAIL exception: %s\n", e.what());
        return 1;
    }
    std::printf("%s\n", failures ? "FAILED" : "ok");
    return failures ? 1 : 0;
}
