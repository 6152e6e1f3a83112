// Annual daylight through the C++ wrapper (imap.hpp): a year of sky vectors from a .wea
// file, Reinhart MF:2 coefficients at an open point (traced in batches of light groups),
// the direct sun on its lines, the hourly illuminance, the metrics and the daylight
// factor. An open horizontal point must read each hour's global horizontal illuminance
// and a daylight factor of 1; bad input throws imap::Error with its status.
#include <imap.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

static int failures = 0;
static const double kPi = 3.14159265358979323846;
#define CHECK(cond, ...)                      \
    do {                                      \
        if (!(cond)) {                        \
            std::printf("FAIL " __VA_ARGS__); \
            std::printf("\n");                \
            failures++;                       \
        }                                     \
    } while (0)

int main() {
    // Four hours at 48 N: night, two overcast, one sunny.
    // A temporary file of a random name (on Linux and Windows alike).
    const std::filesystem::path file = std::filesystem::temp_directory_path() /
        ("imap_annual_hpp_" + std::to_string(std::random_device{}()) + ".wea");
    const std::string path = file.string();
    {
        std::ofstream out(file, std::ios::binary);
        out << "place Cpp\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n"
               "weather_data_file_units 1\n6 21 2.5 0 0\n6 21 9.5 0 80\n6 21 11.5 0 150\n6 21 12.5 600 100\n";
        if (!out) return 1;
    }
    try {
        imap::AnnualSky sky(path, 2);
        CHECK(sky.hours() == 4 && sky.patches() == 578, "sky size %zu × %zu", sky.hours(), sky.patches());
        imap::AnnualSky moved = std::move(sky);
        CHECK(moved.vector(1).size() == 578, "a moved sky keeps its vectors");

        auto cfg = imap::config();
        cfg.threads = 2, cfg.seed = 5;
        imap::Context ctx(cfg);
        auto mat = imap::material();
        double black = 0;
        mat.diffuse_reflectance = &black, mat.diffuse_reflectance_count = 1;
        uint32_t m = ctx.add_material(mat);
        std::vector<double> plate = {-50, -50, -20, 50, -50, -20, 50, 50, -20, -50, 50, -20};
        std::vector<uint32_t> plate_idx = {0, 1, 2, 0, 2, 3};
        auto mesh = imap::mesh();
        mesh.positions = plate.data(), mesh.vertex_count = 4, mesh.indices = plate_idx.data(),
        mesh.triangle_count = 2, mesh.material = m;
        ctx.add_mesh(mesh);
        std::vector<double> sensor = {0, 0, 1, -0.1, -0.1, 1, 0.1, -0.1, 1, 0.1, 0.1, 1, -0.1, 0.1, 1};
        std::vector<uint32_t> sensor_idx = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1};
        mesh = imap::mesh();
        mesh.positions = sensor.data(), mesh.vertex_count = 5, mesh.indices = sensor_idx.data(),
        mesh.triangle_count = 4, mesh.material = m, mesh.flags = IMAP_MESH_SENSOR | IMAP_MESH_RECORD;
        uint32_t id = ctx.add_mesh(mesh);

        imap::Coefficients c = imap::trace_coefficients(ctx, 2, id, 0, {0}, 300000);
        CHECK(c.points == 1 && c.patches == 578 && c.photons >= 300000, "coefficients %zu × %zu, %llu photons",
              c.points, c.patches, static_cast<unsigned long long>(c.photons));
        imap::Hourly df = imap::daylight_factor(c, 2);
        CHECK(std::fabs(df.value[0] - 1) < 4 * df.sigma[0] && df.sigma[0] < 0.1, "daylight factor %g ± %g",
              df.value[0], df.sigma[0]);

        imap::DirectSun sun(ctx, moved, {0, 0, 1}, {0, 0, 1});
        imap::Hourly e = imap::annual_hourly(moved, c, &sun, 0, 4);
        CHECK(e.value[0] == 0, "night reads %g", e.value[0]);
        for (size_t h = 1; h < 4; h++) {
            ImapAnnualHour a = moved.hour(h);
            double want = a.diffuse_horizontal_lx + a.direct_normal_lx * std::cos(a.sun_zenith_deg * kPi / 180);
            CHECK(std::fabs(e.value[h] - want) < 4 * e.sigma[h] + 0.01 * want, "hour %zu: %g ± %g lx, want %g", h,
                  e.value[h], e.sigma[h], want);
            std::printf("hour %zu: %.0f ± %.0f lx (E_h %.0f)\n", h, e.value[h], e.sigma[h], want);
        }
        auto o = imap::annual_options();
        o.ase_hours = 0;
        imap::AnnualMetrics metrics = imap::annual_metrics(moved, c, &sun, o);
        CHECK(metrics.grid.occupied_hours == 3 && metrics.grid.sda == 1 && metrics.grid.ase == 1,
              "metrics: %llu occupied hours, sDA %g, ASE %g",
              static_cast<unsigned long long>(metrics.grid.occupied_hours), metrics.grid.sda, metrics.grid.ase);
        CHECK(metrics.points.size() == 1 && metrics.points[0].da == 1, "the point's DA");

        // Window groups: the point's light as one group whose closed state lets a tenth
        // through and no direct sun, kept closed by a schedule: the point then reads that
        // state alone (cDA at 100 klx: its mean illuminance over 100 klx).
        imap::Coefficients tenth = c;
        for (auto& x : tenth.value) x *= 0.1;
        for (auto& x : tenth.sigma) x *= 0.1;
        std::vector<imap::WindowGroup> groups(1);
        groups[0].states = {&c, &tenth};
        groups[0].suns = {&sun, nullptr};
        groups[0].rule = IMAP_SHADING_SCHEDULE;
        groups[0].schedule.assign(sky.hours(), 1);
        auto dim = o;
        dim.threshold_lx = 1e5;
        imap::AnnualMetrics shut = imap::annual_metrics(moved, nullptr, nullptr, groups, dim);
        CHECK(groups[0].state_hours.size() == 2 && groups[0].state_hours[1] == 3 && shut.grid.blinds_closed_hours == 3,
              "the schedule keeps the group closed in the 3 occupied hours");
        CHECK(shut.grid.ase == 1, "ASE counts the group open: %g", shut.grid.ase);
        imap::AnnualMetrics alone = imap::annual_metrics(moved, tenth, nullptr, dim);
        CHECK(shut.points[0].cda == alone.points[0].cda && alone.points[0].cda > 0.005 && alone.points[0].cda < 0.5,
              "closed all year, the point reads its closed state: cDA %g against %g", shut.points[0].cda,
              alone.points[0].cda);

        // Annual glare with the point as an observer looking up: the glare rule closes the
        // group exactly in the hours whose DGPs with it open (6.22e-5 Ev + 0.184) is above
        // 0.40, and then no hour is above 0.40.
        groups[0].rule = IMAP_SHADING_GLARE;
        groups[0].rule_dgp = 0.40;
        groups[0].schedule.clear();
        std::vector<std::vector<uint16_t>> states = imap::annual_states(moved, nullptr, nullptr, groups);
        for (size_t h = 0; h < 4; h++)
            CHECK(states[0][h] == (6.22e-5 * e.value[h] + 0.184 > 0.40 ? 1 : 0), "hour %zu: state %u at %g lx", h,
                  unsigned(states[0][h]), e.value[h]);
        std::vector<ImapObserverYear> open = imap::annual_glare(moved, c, &sun);
        std::vector<ImapObserverYear> ruled = imap::annual_glare(moved, nullptr, nullptr, groups);
        CHECK(open.size() == 1 && open[0].occupied_hours == 3 && ruled[0].hours_above[1] == 0,
              "DGPs at or above 0.40 in %llu hours open, %llu under the rule",
              static_cast<unsigned long long>(open[0].hours_above[1]),
              static_cast<unsigned long long>(ruled[0].hours_above[1]));

        // Electric light with daylight: the zone's lights give 500 lx; kept at a target
        // above every hour's daylight less 100 lx, they dim to the minimum (30 % power).
        imap::Hourly electric;
        electric.value = {500.0};
        electric.sigma = {5.0};
        ImapDimming d = imap::dimming();
        d.power_w = 2000;
        d.target_lx = 100;
        imap::AnnualLighting light = imap::annual_lighting(moved, c, &sun, electric, d, o);
        CHECK(std::fabs(light.zone.energy_kwh - 3 * 0.3 * 2) < 1e-9 && light.zone.full_kwh == 6,
              "lighting: %g kWh of %g", light.zone.energy_kwh, light.zone.full_kwh);
        CHECK(light.at_target.size() == 1 && light.at_target[0] == 1, "the point meets the target");
        std::printf("lighting: %.2f kWh of %.2f without daylight control\n", light.zone.energy_kwh,
                    light.zone.full_kwh);

        bool thrown = false;
        try {
            imap::trace_coefficients(ctx, 0, id, 0, {0}, 1000);
        } catch (const imap::Error& err) {
            thrown = err.status() == IMAP_ERR_INVALID_ARGUMENT;
            std::printf("mf 0: %s\n", err.what());
        }
        CHECK(thrown, "mf 0 throws IMAP_ERR_INVALID_ARGUMENT");
        thrown = false;
        try {
            imap::AnnualSky none("/nonexistent/site.epw", 1);
        } catch (const imap::Error& err) {
            thrown = err.status() == IMAP_ERR_IO;
        }
        CHECK(thrown, "a missing weather file throws IMAP_ERR_IO");
    } catch (const imap::Error& err) {
        std::printf("FAIL unexpected %s\n", err.what());
        failures++;
    }
    std::filesystem::remove(file);
    std::printf("%s\n", failures ? "FAILED" : "all passed");
    return failures ? 1 : 0;
}
