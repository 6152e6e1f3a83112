// A legacy C++ package's way of holding libimap: a small RAII wrapper that owns the
// context, turns statuses into exceptions carrying the library's message, and reads maps
// into std::vector. The scene is a closed cubic room with grey walls and a point light;
// the program checks the integrating-sphere law: mean wall irradiance = Φ / (A (1 − ρ)).
#include <imap.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace lighting {

class Error : public std::runtime_error {
public:
    Error(ImapStatus s, const std::string& what) : std::runtime_error(what), status(s) {}
    ImapStatus status;
};

class IlluminationMap {
public:
    explicit IlluminationMap(const ImapConfig& cfg) {
        ImapContext* raw = nullptr;
        check(imap_create(&cfg, &raw), nullptr);
        ctx_.reset(raw);
    }

    uint32_t material(double reflectance) {
        ImapMaterial m{};
        m.diffuse_reflectance = &reflectance;
        m.diffuse_reflectance_count = 1;
        uint32_t id = 0;
        check(imap_add_material(ctx_.get(), &m, &id));
        return id;
    }

    uint32_t mesh(const std::vector<double>& xyz, const std::vector<uint32_t>& idx, uint32_t mat) {
        ImapMesh m{};
        m.positions = xyz.data();
        m.vertex_count = xyz.size() / 3;
        m.indices = idx.data();
        m.triangle_count = idx.size() / 3;
        m.material = mat;
        m.flags = IMAP_MESH_RECORD;
        uint32_t id = 0;
        check(imap_add_mesh(ctx_.get(), &m, &id));
        return id;
    }

    void point_light(const double pos[3], double watts) {
        uint32_t id = 0;
        check(imap_add_point_light(ctx_.get(), pos, &watts, 1, &id));
    }

    ImapReport run(uint64_t photons) {
        ImapRunParams p;
        imap_run_params_default(&p);
        p.photons = photons;
        ImapReport r{};
        check(imap_run(ctx_.get(), &p, &r));
        return r;
    }

    std::vector<double> irradiance(uint32_t mesh, uint32_t band) const {
        size_t n = 0;
        check(imap_get_vertex_count(ctx_.get(), mesh, &n));
        std::vector<double> e(n);
        check(imap_get_vertex_energy(ctx_.get(), mesh, IMAP_SIDE_FRONT, band, e.data(), e.size()));
        return e;
    }

private:
    struct Deleter {
        void operator()(ImapContext* c) const { imap_destroy(c); }
    };
    void check(ImapStatus s) const { check(s, ctx_.get()); }
    static void check(ImapStatus s, const ImapContext* c) {
        if (s != IMAP_OK) throw Error(s, std::string(imap_status_name(s)) + ": " + imap_last_error(c));
    }
    std::unique_ptr<ImapContext, Deleter> ctx_;
};

}  // namespace lighting

// A cube [0, 2]³ with n×n cells per face, normals pointing in.
static void cube_room(int n, std::vector<double>& xyz, std::vector<uint32_t>& idx) {
    const double L = 2.0;
    for (int axis = 0; axis < 3; axis++)
        for (int hi = 0; hi < 2; hi++) {
            int u = (axis + 1) % 3, v = (axis + 2) % 3;
            uint32_t base = static_cast<uint32_t>(xyz.size() / 3);
            for (int j = 0; j <= n; j++)
                for (int i = 0; i <= n; i++) {
                    double p[3];
                    p[axis] = hi * L, p[u] = L * i / n, p[v] = L * j / n;
                    xyz.insert(xyz.end(), p, p + 3);
                }
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
                    // u × v = +axis: counter-clockwise in (u, v) faces +axis; the low face
                    // must face +axis (inward), the high face −axis.
                    if (hi == 0) idx.insert(idx.end(), {a, b, c, a, c, d});
                    else idx.insert(idx.end(), {a, c, b, a, d, c});
                }
        }
}

int main() {
    try {
        ImapConfig cfg;
        imap_config_default(&cfg);
        cfg.threads = 2;
        cfg.seed = 11;
        lighting::IlluminationMap map(cfg);
        const double rho = 0.6, watts = 30.0, area = 6 * 2.0 * 2.0;
        std::vector<double> xyz;
        std::vector<uint32_t> idx;
        cube_room(12, xyz, idx);
        uint32_t room = map.mesh(xyz, idx, map.material(rho));
        const double pos[3] = {0.7, 1.1, 0.9};
        map.point_light(pos, watts);
        const uint64_t n = 400000;
        ImapReport r = map.run(n);

        // Area-weighted mean irradiance over the walls (all cells are equal squares, so
        // each vertex's weight is its number of adjacent triangles... computed exactly).
        std::vector<double> e = map.irradiance(room, 0), share(xyz.size() / 3, 0.0);
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
            map.irradiance(room, 7);
            return 1;
        } catch (const lighting::Error& e) {
            std::printf("expected error: %s\n", e.what());
            if (e.status != IMAP_ERR_INDEX_OUT_OF_RANGE) return 1;
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
