// A legacy C++ package's way of holding libimap: the installed C++ wrapper (imap.hpp)
// owns the context, turns statuses into exceptions carrying the library's message, and
// reads maps into std::vector. The scene is a closed cubic room with grey walls and a
// point light; the program checks the integrating-sphere law: mean wall irradiance =
// Φ / (A (1 − ρ)). It also checks that an exception thrown in the progress callback
// stops the run and reaches the caller, and that the map survives it; then the same law in
// lux for a luminaire from IES text (1000 lm, 3000 K).
#include <imap.hpp>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

// A closed cube [0, 2]³ with n × n cells per face, normals pointing in.
static void cube_room(int n, std::vector<double>& xyz, std::vector<uint32_t>& idx) {
    const double s = 2.0;
    for (int axis = 0; axis < 3; axis++)
        for (int hi = 0; hi < 2; hi++) {
            uint32_t base = static_cast<uint32_t>(xyz.size() / 3);
            int u = (axis + 1) % 3, v = (axis + 2) % 3;
            for (int j = 0; j <= n; j++)
                for (int i = 0; i <= n; i++) {
                    double p[3];
                    p[axis] = hi * s, p[u] = s * i / n, p[v] = s * j / n;
                    xyz.insert(xyz.end(), {p[0], p[1], p[2]});
                }
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
                    // The normal u × v points along +axis: flip on the far face so both
                    // face into the room.
                    if (hi == 0) idx.insert(idx.end(), {a, b, c, a, c, d});
                    else idx.insert(idx.end(), {a, c, b, a, d, c});
                }
        }
}

int main() {
    try {
        ImapConfig cfg = imap::config();
        cfg.threads = 2;
        cfg.seed = 11;
        imap::Context map(cfg);
        const double rho = 0.6, watts = 30.0, area = 6 * 2.0 * 2.0;
        std::vector<double> xyz;
        std::vector<uint32_t> idx;
        cube_room(12, xyz, idx);
        ImapMaterial grey = imap::material();
        grey.diffuse_reflectance = &rho;
        grey.diffuse_reflectance_count = 1;
        ImapMesh walls = imap::mesh();
        walls.positions = xyz.data(), walls.vertex_count = xyz.size() / 3;
        walls.indices = idx.data(), walls.triangle_count = idx.size() / 3;
        walls.material = map.add_material(grey);
        walls.flags = IMAP_MESH_RECORD;
        uint32_t room = map.add_mesh(walls);
        map.add_point_light({0.7, 1.1, 0.9}, {watts});
        const uint64_t n = 400000;
        ImapRunParams params = imap::run_params();
        params.photons = n;
        ImapReport r = map.run(params);

        // Area-weighted mean irradiance over the walls (all cells are equal squares, so
        // each vertex's weight is its number of adjacent triangles... computed exactly).
        std::vector<double> e = map.irradiance(room, IMAP_SIDE_FRONT, 0), share(xyz.size() / 3, 0.0);
        for (size_t t = 0; t < idx.size(); t += 3)
            for (int k = 0; k < 3; k++) share[idx[t + k]] += (2.0 / 12) * (2.0 / 12) / 2 / 3;
        double mean = 0;
        for (size_t v = 0; v < e.size(); v++) mean += e[v] * share[v];
        mean /= area;
        double expected = watts / (area * (1 - rho));
        double sigma = std::sqrt(rho / n);  // hits per photon are geometric
        std::printf("room: %llu photons, %llu hits; mean irradiance %.5f W/m², integrating-sphere law %.5f (%.2f σ)\n",
                    static_cast<unsigned long long>(r.photons), static_cast<unsigned long long>(r.hits), mean, expected,
                    (mean / expected - 1) / sigma);
        if (std::fabs(mean / expected - 1) > 4 * sigma) return 1;

        // A bad call becomes an exception carrying the library's message.
        try {
            map.irradiance(room, IMAP_SIDE_FRONT, 7);
            return 1;
        } catch (const imap::Error& e) {
            std::printf("expected error: %s\n", e.what());
            if (e.status() != IMAP_ERR_INDEX_OUT_OF_RANGE) return 1;
        }

        // A callback that throws: the run stops, the exception reaches us, and the map
        // holds exactly the whole photons traced (a later run continues from there).
        ImapRunParams more = imap::run_params();
        more.time_budget_s = 30;
        more.progress_interval_s = 0.01;
        int calls = 0;
        try {
            map.run(more, [&](const ImapProgress&) -> bool {
                if (++calls == 3) throw std::runtime_error("host gave up");
                return true;
            });
            return 1;
        } catch (const std::runtime_error& e) {
            ImapReport after = map.report();
            std::printf("callback threw \"%s\" after %d calls: %llu photons in the map, stop reason %u\n", e.what(), calls,
                        static_cast<unsigned long long>(after.photons), after.stop_reason);
            if (calls != 3 || after.photons <= n || after.stop_reason != IMAP_STOP_CANCELLED) return 1;
        }

        // Photometry: the same room lit by a luminaire from IES text, set to 1000 lm of
        // 3000 K light: mean wall illuminance = Φv / (A (1 − ρ)), and the light's colour.
        imap::Context lit(cfg);
        walls.material = lit.add_material(grey);
        uint32_t room2 = lit.add_mesh(walls);
        const std::string ies =
            "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 20\n0 90 180\n0\n900 500 100\n";
        ImapLuminaire place = imap::luminaire();
        place.position[0] = 1.0, place.position[1] = 1.0, place.position[2] = 1.5;
        place.lumens = 1000;
        ImapSpectrum warm = imap::spectrum();
        warm.kind = IMAP_SPECTRUM_BLACKBODY, warm.cct_k = 3000;
        uint32_t lum = lit.add_luminaire_ies(ies, place, &warm);
        lit.set_layers(IMAP_KEEP_DIRECT);
        lit.run(params);
        std::vector<double> lux = lit.illuminance(room2, IMAP_SIDE_FRONT), tri = lit.xyz(room2, IMAP_SIDE_FRONT);
        double mean_lux = 0;
        std::array<double, 3> sum{};
        for (size_t v = 0; v < lux.size(); v++) {
            mean_lux += lux[v] * share[v];
            for (int k = 0; k < 3; k++) sum[k] += tri[3 * v + k] * share[v];
        }
        mean_lux /= area;
        double want = lit.light_lumens(lum) / (area * (1 - rho));
        std::array<double, 2> cct = imap::cct(sum);
        std::printf("luminaire: %.1f lm; mean illuminance %.3f lx, integrating-sphere law %.3f (%.2f σ); %.0f K\n",
                    lit.light_lumens(lum), mean_lux, want, (mean_lux / want - 1) / sigma, cct[0]);
        if (std::fabs(mean_lux / want - 1) > 4 * sigma || std::fabs(cct[0] - 3000) > 5) return 1;
        // The region figures: the walls' vertex areas are the shares above, and their Eavg
        // (summed from the vertices: the walls keep no tallies) is the mean just computed.
        std::vector<double> areas = lit.vertex_areas(room2);
        for (size_t v = 0; v < areas.size(); v++)
            if (std::fabs(areas[v] - share[v]) > 1e-12) return 1;
        ImapRegionStats rs = lit.region_stats(room2, IMAP_SIDE_FRONT);
        std::printf("walls: Eavg %.3f ± %.3f lx (bound), Emin %.3f ± %.3f lx, U0 %.4f ± %.4f\n", rs.average_lx,
                    rs.average_lx_sigma, rs.min_lx, rs.min_lx_sigma, rs.u0, rs.u0_sigma);
        if (std::fabs(rs.average_lx / mean_lux - 1) > 1e-9 || rs.errors_exact != 0 || std::fabs(rs.area_m2 - area) > 1e-9)
            return 1;
        // The direct layer: every photon's first surface is a wall, so the walls' mean direct
        // illuminance is Φv / A without noise (to the f32 rounding of the deposits' colours),
        // and the rest of the mean is indirect.
        std::vector<double> direct = lit.layer_illuminance(room2, IMAP_SIDE_FRONT, IMAP_LAYER_DIRECT);
        double mean_direct = 0;
        for (size_t v = 0; v < direct.size(); v++) mean_direct += direct[v] * share[v];
        mean_direct /= area;
        double want_direct = lit.light_lumens(lum) / area;
        std::printf("walls: direct %.6f lx (Φv/A = %.6f), indirect %.3f lx\n", mean_direct, want_direct,
                    mean_lux - mean_direct);
        // Exact with photons only; light sampling (the default estimator) estimates the
        // direct light by shadow rays, which agree to well within their error here.
        if (std::fabs(mean_direct / want_direct - 1) > 1e-3 || lit.light_group_layers() != 0) return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
