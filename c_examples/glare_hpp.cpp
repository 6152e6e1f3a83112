// Glare at a desk through imap.hpp: a 6 × 4 × 3 m office of grey surfaces (ρ = 0.5) lit
// by two 0.6 m square Lambertian ceiling panels, an observer seated at 1.2 m looking along
// the room. The observer's sensor gives its vertical illuminance with its error, and
// observer_glare() its UGR (CIE 117) with each panel's luminance, solid angle and position
// index, the background luminance and DGPs. An eye turned to the wall sees no panel; an
// observer with a zero view is refused with imap::Error.
#include <imap.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

static int failures = 0;
#define CHECK(cond, ...)                      \
    do {                                      \
        if (!(cond)) {                        \
            std::printf("FAIL " __VA_ARGS__); \
            std::printf("\n");                \
            failures++;                       \
        }                                     \
    } while (0)

int main() {
    imap::Context ctx;
    static const double rho = 0.5;
    ImapMaterial grey = imap::material();
    grey.diffuse_reflectance = &rho;
    grey.diffuse_reflectance_count = 1;
    const uint32_t mat = ctx.add_material(grey);

    // The room's six faces, each a quad facing in.
    const double X = 6, Y = 4, Z = 3;
    std::vector<double> xyz = {0, 0, 0, X, 0, 0, X, Y, 0, 0, Y, 0, 0, 0, Z, X, 0, Z, X, Y, Z, 0, Y, Z};
    std::vector<uint32_t> idx = {
        0, 1, 2, 0, 2, 3,  // floor, up
        4, 6, 5, 4, 7, 6,  // ceiling, down
        0, 4, 5, 0, 5, 1,  // y = 0
        3, 2, 6, 3, 6, 7,  // y = Y
        0, 3, 7, 0, 7, 4,  // x = 0
        1, 5, 6, 1, 6, 2,  // x = X
    };
    ImapMesh room = imap::mesh();
    room.positions = xyz.data();
    room.vertex_count = xyz.size() / 3;
    room.indices = idx.data();
    room.triangle_count = idx.size() / 3;
    room.material = mat;
    ctx.add_mesh(room);

    // I(γ) = 1000 cos γ: 1000 / 0.36 = 2778 cd/m² from every direction below.
    std::vector<double> vertical, candela, horizontal = {0.0};
    for (int k = 0; k <= 18; k++) {
        vertical.push_back(10.0 * k);
        candela.push_back(k <= 9 ? std::max(0.0, 1000.0 * std::cos(10.0 * k * 3.14159265358979 / 180)) : 0.0);
    }
    ImapPhotometry t;
    imap_photometry_default(&t, sizeof t);
    t.photometric_type = IMAP_PHOTOMETRY_C;
    t.vertical = vertical.data();
    t.vertical_count = vertical.size();
    t.horizontal = horizontal.data();
    t.horizontal_count = 1;
    t.candela = candela.data();
    t.opening = IMAP_OPENING_RECTANGLE;
    t.opening_width = t.opening_length = 0.6;
    for (double x : {2.5, 4.5}) {
        ImapLuminaire place = imap::luminaire();
        place.position[0] = x, place.position[1] = 2.0, place.position[2] = Z - 0.01;
        ctx.add_luminaire_table(t, place);
    }

    const ImapObserver desk = imap::observer({0.8, 2.0, 1.2}, {1.0, 0.0, 0.0});
    const uint32_t eye = ctx.add_observer_sensor(desk, 0.05);
    ImapRunParams p = imap::run_params();
    p.photons = 400000;
    // Gathering: the light the room reflects into the eye, gathered from the map.
    p.estimator = IMAP_ESTIMATOR_GATHER;
    ctx.run(p);

    const imap::Glare g = ctx.observer_glare(desk, eye);
    std::printf("desk: Ev %.1f ± %.2f lx (%.1f lx direct), background %.2f cd/m², UGR %.2f ± %.3f, DGPs %.3f\n",
                g.figures.ev_lx, g.figures.ev_sigma_lx, g.figures.direct_lx, g.figures.background_cd_m2,
                g.figures.ugr, g.figures.ugr_sigma, g.figures.dgps);
    for (const ImapGlareSource& s : g.sources)
        std::printf("  luminaire %u: L %.0f cd/m², ω %.4f sr, p %.2f, %.1f lx\n", s.id, s.luminance_cd_m2,
                    s.solid_angle_sr, s.position_index, s.ev_lx);
    CHECK(g.sources.size() == 2, "both panels in view: %zu", g.sources.size());
    for (const ImapGlareSource& s : g.sources)
        CHECK(std::fabs(s.luminance_cd_m2 - 1000.0 / 0.36) < 0.01 * 1000.0 / 0.36, "panel luminance %g", s.luminance_cd_m2);
    // The room's walls reflect half of what they get: the eye sees a lit background.
    CHECK(g.figures.background_cd_m2 > 0 && g.figures.ev_lx > g.figures.direct_lx, "a background");
    CHECK(std::isfinite(g.figures.ugr) && g.figures.ugr_sigma > 0 && g.figures.ugr_sigma < 0.5, "UGR %g ± %g",
          g.figures.ugr, g.figures.ugr_sigma);
    // Given its Ev and σ directly, the same figures.
    const imap::Glare h = ctx.observer_glare(desk, g.figures.ev_lx, g.figures.ev_sigma_lx);
    CHECK(h.figures.ugr == g.figures.ugr && h.sources.size() == 2, "the same glare");

    // Facing the wall behind: no panel in view, nothing to rate.
    const imap::Glare away = ctx.observer_glare(imap::observer({0.8, 2.0, 1.2}, {-1.0, 0.0, 0.0}), 100.0, 1.0);
    CHECK(away.sources.empty() && away.figures.ugr_below_10 == 1, "no source behind");

    try {
        ctx.observer_glare(imap::observer({0.8, 2.0, 1.2}, {0.0, 0.0, 0.0}), 100.0, 1.0);
        CHECK(false, "a zero view was accepted");
    } catch (const imap::Error& e) {
        CHECK(e.status() == IMAP_ERR_INVALID_ARGUMENT, "zero view: %s", e.what());
    }
    std::printf("%s\n", failures ? "FAILED" : "glare_hpp: all checks passed");
    return failures ? 1 : 0;
}
