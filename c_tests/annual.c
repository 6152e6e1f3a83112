/*
 * Annual daylight through the C API: a weather file's sky vectors, the Tregenza patches as
 * light groups, their coefficients at an open horizontal sensor, the direct sun on its
 * lines, the hourly illuminance and the metrics, and the daylight factor; checked against
 * what an open point must read. Bad input gets its own status and a message, and freed
 * handles are refused.
 */
#define _DEFAULT_SOURCE
#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
#endif

static int failures = 0;
static const double PI = 3.14159265358979323846;

static void check(const char *what, int ok, double got, double want) {
    if (!ok) {
        printf("FAIL %-52s got %.6g, want %.6g\n", what, got, want);
        failures++;
    } else {
        printf("ok   %-52s %.6g (%.6g)\n", what, got, want);
    }
}

static void expect(const char *what, ImapStatus status, ImapStatus want) {
    const char *msg = imap_last_error(NULL);
    if (status != want || (want != IMAP_OK && (msg == NULL || msg[0] == '\0'))) {
        printf("FAIL %-52s got %s, want %s (%s)\n", what, imap_status_name(status), imap_status_name(want),
               msg ? msg : "(null)");
        failures++;
    } else {
        printf("ok   %-52s %s%s%s\n", what, imap_status_name(status), want != IMAP_OK ? ": " : "",
               want != IMAP_OK ? msg : "");
    }
}

/* Four hours at 48 N: night, two overcast, one sunny. */
static const char *WEA = "place CTest\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n"
                         "weather_data_file_units 1\n"
                         "6 21 2.5 0 0\n6 21 9.5 0 80\n6 21 11.5 0 150\n6 21 12.5 600 100\n";

/* A black plate far below, and a small sensor square at z = 1 facing up (its centre vertex 0). */
static double plate[12] = {-50, -50, -20, 50, -50, -20, 50, 50, -20, -50, 50, -20};
static uint32_t plate_idx[6] = {0, 1, 2, 0, 2, 3};
static double sensor[15] = {0, 0, 1, -0.1, -0.1, 1, 0.1, -0.1, 1, 0.1, 0.1, 1, -0.1, 0.1, 1};
static uint32_t sensor_idx[12] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1};

/* Each lit hour (1-3) at the open point reads the hour's E_h: diffuse and direct sun on
 * the horizontal, within 4 sigma and 1 % for the patches. */
static void check_hours(const ImapAnnualSky *sky, const double *e, const double *s, const char *label) {
    for (int h = 1; h < 4; h++) {
        ImapAnnualHour a;
        imap_annual_sky_hour(sky, (size_t)h, &a, sizeof a);
        double w = a.diffuse_horizontal_lx + a.direct_normal_lx * cos(a.sun_zenith_deg * PI / 180);
        char what[64];
        snprintf(what, sizeof what, "%shour %d reads E_h (4 sigma, 1 %% patches)", label, h);
        check(what, fabs(e[h] - w) < 4 * s[h] + 0.01 * w, e[h], w);
    }
}

/* The black plate and the sensor in `ctx`; the sensor's mesh id goes to `sensor_id`. */
static void model(ImapContext *ctx, uint32_t *sensor_id) {
    double black = 0;
    ImapMaterial mat;
    imap_material_default(&mat, sizeof mat);
    mat.diffuse_reflectance = &black, mat.diffuse_reflectance_count = 1;
    uint32_t m_black = 0, id = 0;
    expect("material", imap_add_material(ctx, &mat, &m_black), IMAP_OK);
    ImapMesh mesh;
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = plate, mesh.vertex_count = 4, mesh.indices = plate_idx, mesh.triangle_count = 2;
    mesh.material = m_black;
    expect("plate", imap_add_mesh(ctx, &mesh, &id), IMAP_OK);
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = sensor, mesh.vertex_count = 5, mesh.indices = sensor_idx, mesh.triangle_count = 4;
    mesh.material = m_black, mesh.flags = IMAP_MESH_SENSOR | IMAP_MESH_RECORD;
    expect("sensor", imap_add_mesh(ctx, &mesh, sensor_id), IMAP_OK);
}

/* A new file PATH ending in .wea, in the system's temporary folder, open for writing. */
static FILE *temp_wea(char *path, size_t size) {
#ifdef _WIN32
    /* Windows has no mkstemps: GetTempFileNameA creates a unique file, which is then renamed
       to the .wea name the reader asks for (MoveFileA refuses an existing name). */
    char dir[MAX_PATH], tmp[MAX_PATH];
    if (!GetTempPathA(sizeof dir, dir) || !GetTempFileNameA(dir, "ima", 0, tmp)) return NULL;
    snprintf(path, size, "%s.wea", tmp);
    if (!MoveFileA(tmp, path)) {
        DeleteFileA(tmp);
        return NULL;
    }
    return fopen(path, "w");
#else
    snprintf(path, size, "/tmp/imap_annual_XXXXXX.wea");
    int fd = mkstemps(path, 4);
    return fd < 0 ? NULL : fdopen(fd, "w");
#endif
}

int main(void) {
    char path[512];
    FILE *f = temp_wea(path, sizeof path);
    if (f == NULL) {
        perror("a temporary .wea file");
        return 1;
    }
    fputs(WEA, f);
    fclose(f);

    ImapAnnualSky *sky = NULL;
    expect("sky from a .wea", imap_annual_sky_read(path, 1, 0.2, &sky), IMAP_OK);
    ImapAnnualSky *other = NULL;
    expect("mf 0", imap_annual_sky_read(path, 0, 0.2, &other), IMAP_ERR_INVALID_ARGUMENT);
    expect("ground reflectance 2", imap_annual_sky_read(path, 1, 2.0, &other), IMAP_ERR_INVALID_ARGUMENT);
    size_t hours = 0, patches = 0;
    expect("sky size", imap_annual_sky_size(sky, &hours, &patches), IMAP_OK);
    check("hours", hours == 4, (double)hours, 4);
    check("patches (Tregenza and the ground)", patches == 146, (double)patches, 146);
    ImapAnnualHour h3;
    expect("hour 3", imap_annual_sky_hour(sky, 3, &h3, sizeof h3), IMAP_OK);
    check("hour 3 has its sun in a patch", h3.sun_patch > 0 && h3.direct_normal_lx > 10000, h3.direct_normal_lx, 0);
    double vec[146];
    expect("hour 1's vector", imap_annual_sky_vector(sky, 1, vec, 146), IMAP_OK);

    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 2, cfg.seed = 3;
    ImapContext *ctx = NULL;
    expect("imap_create", imap_create(&cfg, &ctx), IMAP_OK);
    uint32_t sensor_id = 0;
    model(ctx, &sensor_id);
    expect("MF:2 is refused (more than 254 groups)", imap_add_sky_patches(ctx, 2, NULL, NULL, NULL),
           IMAP_ERR_INVALID_ARGUMENT);
    uint32_t first = 0;
    expect("Tregenza patches", imap_add_sky_patches(ctx, 1, NULL, NULL, &first), IMAP_OK);
    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.photons = 300000, run.estimator = IMAP_ESTIMATOR_GATHER;
    expect("coefficients' run", imap_run(ctx, &run, NULL, 0), IMAP_OK);

    uint32_t centre = 0;
    double value[146], sigma[146];
    expect("coefficients", imap_annual_coefficients(ctx, sensor_id, 0, &centre, 1, 1, value, sigma), IMAP_OK);
    uint32_t bad_vertex = 5;
    expect("coefficients of vertex 5 of 5", imap_annual_coefficients(ctx, sensor_id, 0, &bad_vertex, 1, 1, value, sigma),
           IMAP_ERR_INDEX_OUT_OF_RANGE);

    /* An open horizontal point: the daylight factor is 100 % within its error. */
    double df = 0, df_sigma = 0;
    expect("daylight factor", imap_daylight_factor(value, sigma, 1, 1, 0.2, &df, &df_sigma), IMAP_OK);
    check("open point's daylight factor is 1 (4 sigma)", fabs(df - 1) < 4 * df_sigma && df_sigma < 0.1, df, 1);

    double pt[3] = {0, 0, 1}, up[3] = {0, 0, 1};
    ImapDirectSun *sun = NULL;
    expect("direct sun", imap_direct_sun_new(ctx, sky, pt, up, 1, NULL, NULL, 1, &sun), IMAP_OK);
    double direct = 0;
    expect("direct sun in hour 3", imap_direct_sun_hour(sun, 3, &direct, 1), IMAP_OK);
    double want = h3.direct_normal_lx * cos(h3.sun_zenith_deg * PI / 180);
    check("hour 3's direct sun is E_n cos Z", fabs(direct / want - 1) < 1e-5, direct, want);

    /* Each hour: the vector's horizontal illuminance plus the sun's, within the error. */
    double e[4], s[4];
    expect("hourly", imap_annual_hourly(sky, value, sigma, 1, sun, 0, 4, e, s), IMAP_OK);
    check("night reads 0", e[0] == 0, e[0], 0);
    check_hours(sky, e, s, "");
    expect("hourly past the end", imap_annual_hourly(sky, value, sigma, 1, sun, 2, 3, e, s),
           IMAP_ERR_INDEX_OUT_OF_RANGE);

    ImapAnnualOptions o;
    imap_annual_options_default(&o, sizeof o);
    o.ase_hours = 0;
    ImapAnnualMetrics m;
    ImapSensorMetrics per;
    expect("metrics", imap_annual_metrics(sky, value, sigma, 1, sun, &o, &m, sizeof m, &per, sizeof per), IMAP_OK);
    check("occupied hours (sun up)", m.occupied_hours == 3, (double)m.occupied_hours, 3);
    check("ASE (1 hour > 0)", m.ase == 1, m.ase, 1);
    check("the point's ASE hours", per.ase_hours == 1, (double)per.ase_hours, 1);
    check("DA at 300 lx", per.da == 1, per.da, 1);
    check("sDA", m.sda == 1, m.sda, 1);
    check("EN 17037: high (2 daylight hours of 4)", m.en17037_level == 2 && m.daylight_hours == 2,
          (double)m.en17037_level, 2);
    check("UDI: above 3000 lx in every sunlit hour", m.udi[2] == 1 && m.udi[1] == 0 && m.udi[0] == 0, m.udi[2], 1);
    check("UDI's interval", m.udi_interval_low[2] <= 1 && m.udi_interval_high[2] == 1, m.udi_interval_low[2], 1);
    ImapAnnualMetrics before_udi;
    expect("metrics into the struct as it was before UDI's fields",
           imap_annual_metrics(sky, value, sigma, 1, sun, &o, &before_udi, offsetof(ImapAnnualMetrics, udi), NULL, 0),
           IMAP_OK);
    check("its struct_size", before_udi.struct_size == offsetof(ImapAnnualMetrics, udi),
          (double)before_udi.struct_size, (double)offsetof(ImapAnnualMetrics, udi));
    o.threshold_lx = -1;
    expect("metrics with threshold -1", imap_annual_metrics(sky, value, sigma, 1, sun, &o, &m, sizeof m, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT);
    imap_annual_options_default(&o, sizeof o);
    unsigned char occ[3] = {1, 1, 1};
    o.occupied = occ, o.occupied_count = 3;
    expect("occupied of 3 hours for 4", imap_annual_metrics(sky, value, sigma, 1, sun, &o, &m, sizeof m, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT);
    double nan_value[146];
    memcpy(nan_value, value, sizeof value);
    nan_value[7] = NAN;
    expect("a NaN coefficient", imap_annual_metrics(sky, nan_value, sigma, 1, NULL, NULL, &m, sizeof m, NULL, 0),
           IMAP_ERR_NON_FINITE);

    /* Window groups: the point's light as one group of two states (open, and a closed
       state of half its coefficients and no direct sun), no base. */
    double half[146], hsig[146], zero[146] = {0};
    for (int p = 0; p < 146; p++) half[p] = 0.5 * value[p], hsig[p] = 0.5 * sigma[p];
    const double *gv[2] = {value, half}, *gs[2] = {sigma, hsig};
    const ImapDirectSun *gsun[2] = {sun, NULL};
    uint64_t state_hours[2] = {9, 9};
    uint16_t closed_all[4] = {1, 1, 1, 1}, open_all_hours[4] = {0, 0, 0, 0};
    ImapWindowGroup g;
    expect("window group defaults", imap_window_group_default(&g, sizeof g), IMAP_OK);
    check("LM-83's rule by default", g.rule == IMAP_SHADING_DIRECT_SUN, g.rule, IMAP_SHADING_DIRECT_SUN);
    g.state_count = 2, g.value = gv, g.sigma = gs, g.sun = gsun, g.state_hours = state_hours;
    const ImapWindowGroup *groups[1] = {&g};
    imap_annual_options_default(&o, sizeof o);
    o.ase_hours = 0, o.window_groups = groups, o.window_group_count = 1;
    /* LM-83's rule: closed in the occupied hours whose direct sun exceeds 1000 lx (the one
       point is 100 % of the points). */
    int sunny = 0;
    for (int h = 1; h < 4; h++) {
        double d = 0;
        imap_direct_sun_hour(sun, (size_t)h, &d, 1);
        sunny += d > 1000;
    }
    ImapAnnualMetrics gm;
    expect("metrics of a window group", imap_annual_metrics(sky, NULL, NULL, 1, NULL, &o, &gm, sizeof gm, NULL, 0),
           IMAP_OK);
    check("the group's closed hours are the sunny ones", state_hours[1] == (uint64_t)sunny && state_hours[0] + state_hours[1] == 3,
          (double)state_hours[1], sunny);
    check("blinds_closed_hours counts them", gm.blinds_closed_hours == (uint64_t)sunny, (double)gm.blinds_closed_hours, sunny);
    check("ASE counts the group open", gm.ase == 1, gm.ase, 1);
    /* A schedule that keeps the group in a closed state of no light: DA 0. */
    const double *dark[2] = {value, zero}, *dark_s[2] = {sigma, zero};
    g.value = dark, g.sigma = dark_s, g.rule = IMAP_SHADING_SCHEDULE, g.schedule = closed_all, g.schedule_count = 4;
    expect("metrics with a schedule", imap_annual_metrics(sky, NULL, NULL, 1, NULL, &o, &gm, sizeof gm, &per, sizeof per),
           IMAP_OK);
    check("closed every hour: DA 0", per.da == 0 && state_hours[1] == 3, per.da, 0);
    double ge[4], gs_[4];
    expect("hourly with the group", imap_annual_hourly_shaded(sky, NULL, NULL, 1, NULL, &o, 0, 4, ge, gs_), IMAP_OK);
    check("closed every hour: 0 lx each hour", ge[1] == 0 && ge[2] == 0 && ge[3] == 0, ge[3], 0);
    g.schedule = open_all_hours;
    expect("hourly with the group open", imap_annual_hourly_shaded(sky, NULL, NULL, 1, NULL, &o, 0, 4, ge, gs_), IMAP_OK);
    check("open every hour: the point's own hours", ge[3] == e[3] && gs_[3] == s[3], ge[3], e[3]);
    expect("a base's sun without its coefficients", imap_annual_hourly_shaded(sky, NULL, NULL, 1, sun, &o, 0, 4, ge, gs_),
           IMAP_ERR_INVALID_ARGUMENT);
    expect("hourly past the end with the group", imap_annual_hourly_shaded(sky, NULL, NULL, 1, NULL, &o, 2, 3, ge, gs_),
           IMAP_ERR_INDEX_OUT_OF_RANGE);
    g.schedule = closed_all;
    /* The base and one group of one state add up: the point's coefficients halved twice. */
    const double *halves[1] = {half}, *halves_s[1] = {hsig};
    g.state_count = 1, g.value = halves, g.sigma = halves_s, g.sun = NULL, g.rule = IMAP_SHADING_SCHEDULE;
    uint16_t open_all[4] = {0, 0, 0, 0};
    g.schedule = open_all;
    ImapSensorMetrics whole;
    ImapAnnualOptions bright;
    imap_annual_options_default(&bright, sizeof bright);
    bright.threshold_lx = 1e6; /* cDA is then the mean illuminance over 1e6 lx */
    o.threshold_lx = 1e6;
    expect("the whole point", imap_annual_metrics(sky, value, sigma, 1, NULL, &bright, &gm, sizeof gm, &whole, sizeof whole),
           IMAP_OK);
    expect("half as the base, half as a group", imap_annual_metrics(sky, half, hsig, 1, NULL, &o, &gm, sizeof gm, &per, sizeof per),
           IMAP_OK);
    check("the parts' cDA is the whole's", fabs(per.cda - whole.cda) < 1e-12 * whole.cda && whole.cda > 0 && whole.cda < 1,
          per.cda, whole.cda);
    /* Bad groups, each named; an options struct of the size before window groups still reads. */
    g.schedule = closed_all;
    expect("a schedule asking for state 1 of 1", imap_annual_metrics(sky, half, hsig, 1, NULL, &o, &gm, sizeof gm, NULL, 0),
           IMAP_ERR_INDEX_OUT_OF_RANGE);
    g.rule = 7;
    expect("rule 7", imap_annual_metrics(sky, half, hsig, 1, NULL, &o, &gm, sizeof gm, NULL, 0), IMAP_ERR_INVALID_ARGUMENT);
    check("the message names the group", strstr(imap_last_error(NULL), "window_groups[0]") != NULL, 0, 0);
    g.rule = IMAP_SHADING_SCHEDULE, g.schedule = open_all, g.state_count = 0;
    expect("a group of no state", imap_annual_metrics(sky, half, hsig, 1, NULL, &o, &gm, sizeof gm, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT);
    g.state_count = 1;
    o.shaded_value = half, o.shaded_sigma = hsig;
    expect("blinds and window groups at once", imap_annual_metrics(sky, value, sigma, 1, sun, &o, &gm, sizeof gm, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT);
    imap_annual_options_default(&o, sizeof o);
    o.struct_size = offsetof(ImapAnnualOptions, window_groups);
    expect("options of the size before window groups", imap_annual_metrics(sky, value, sigma, 1, sun, &o, &gm, sizeof gm, NULL, 0),
           IMAP_OK);

    /* Electric light with daylight: a target 1000 lx above the brightest sunlit hour, the
       zone's lights at full output bringing the dimmest hour to it at 90 % output. */
    double emin = e[1], emax = e[1];
    for (int h = 2; h < 4; h++) emin = e[h] < emin ? e[h] : emin, emax = e[h] > emax ? e[h] : emax;
    double el = (emax + 1000 - emin) / 0.9, el_sigma = 0.01 * el, at = -1;
    ImapDimming dim;
    expect("dimming defaults", imap_dimming_default(&dim, sizeof dim), IMAP_OK);
    check("EnergyPlus's minimum output", dim.min_output == 0.2 && dim.min_power == 0.3, dim.min_output, 0.2);
    dim.power_w = 1000;
    dim.target_lx = emax + 1000;
    ImapLighting light;
    expect("lighting", imap_annual_lighting(sky, value, sigma, 1, sun, NULL, &el, &el_sigma, &dim, &light,
                                            sizeof light, &at), IMAP_OK);
    double kwh = 0;
    for (int h = 1; h < 4; h++) {
        double f = (dim.target_lx - e[h]) / el;
        f = f < 0.2 ? 0.2 : f;
        kwh += 0.3 + 0.7 * (f - 0.2) / 0.8;
    }
    check("continuous dimming's energy, three sunlit hours", fabs(light.energy_kwh - kwh) < 1e-9, light.energy_kwh, kwh);
    check("full output's energy", light.full_kwh == 3 && light.occupied_hours == 3, light.full_kwh, 3);
    check("the photosensor meets its target every hour", at == 1, at, 1);
    check("the energy's interval holds it", light.energy_low <= light.energy_kwh && light.energy_kwh <= light.energy_high,
          light.energy_low, light.energy_kwh);
    dim.control = IMAP_LIGHTING_CONTINUOUS_OFF, dim.target_lx = 1;
    expect("lighting, off", imap_annual_lighting(sky, value, sigma, 1, sun, NULL, &el, &el_sigma, &dim, &light,
                                                 sizeof light, NULL), IMAP_OK);
    check("daylight alone: off every hour", light.energy_kwh == 0 && light.hours_off == 3, light.energy_kwh, 0);
    dim.sensor = 1;
    expect("a photosensor past the sensors", imap_annual_lighting(sky, value, sigma, 1, sun, NULL, &el, &el_sigma, &dim,
                                                                  &light, sizeof light, NULL),
           IMAP_ERR_INDEX_OUT_OF_RANGE);
    dim.sensor = 0, dim.control = 9;
    expect("control 9", imap_annual_lighting(sky, value, sigma, 1, sun, NULL, &el, &el_sigma, &dim, &light,
                                             sizeof light, NULL), IMAP_ERR_INVALID_ARGUMENT);
    dim.control = IMAP_LIGHTING_CONTINUOUS, dim.struct_size = 4;
    expect("a dimming of 4 bytes", imap_annual_lighting(sky, value, sigma, 1, sun, NULL, &el, &el_sigma, &dim, &light,
                                                       sizeof light, NULL), IMAP_ERR_INVALID_ARGUMENT);

    /* Annual glare, imageless: the point as an observer looking up. Each occupied hour's
       DGPs is 6.22e-5 Ev + 0.184 of its hourly Ev (e[], the sun included); the classes
       count the hours at or above 0.35, 0.40 and 0.45. */
    ImapObserverYear year;
    expect("annual glare", imap_annual_glare(sky, value, sigma, 1, sun, NULL, &year, sizeof year), IMAP_OK);
    const double classes[3] = {0.35, 0.40, 0.45};
    for (int c = 0; c < 3; c++) {
        uint64_t n = 0;
        for (int h = 1; h < 4; h++) n += 6.22e-5 * e[h] + 0.184 >= classes[c];
        check("the hours at or above a DGP class", year.hours_above[c] == n && year.occupied_hours == 3,
              (double)year.hours_above[c], (double)n);
        check("its share's interval holds it",
              year.share_low[c] <= year.share_above[c] && year.share_above[c] <= year.share_high[c],
              year.share_above[c], year.share_low[c]);
    }
    check("the mean Ev", fabs(year.mean_ev_lx - (e[1] + e[2] + e[3]) / 3) < 1e-9 * year.mean_ev_lx,
          year.mean_ev_lx, (e[1] + e[2] + e[3]) / 3);
    expect("annual glare into a 2-byte element", imap_annual_glare(sky, value, sigma, 1, sun, NULL, &year, 2),
           IMAP_ERR_INVALID_ARGUMENT);
    /* The glare rule: the point's light as one group (open; a dark state), closed exactly
       in the hours whose DGPs with it open exceeds 0.40, read back by imap_annual_states. */
    {
        const double *gv2[2] = {value, zero}, *gs2[2] = {sigma, zero};
        const ImapDirectSun *gsun2[2] = {sun, NULL};
        ImapWindowGroup gg;
        expect("window group defaults", imap_window_group_default(&gg, sizeof gg), IMAP_OK);
        check("the glare rule's default DGPs", gg.rule_dgp == 0.40, gg.rule_dgp, 0.40);
        gg.rule = IMAP_SHADING_GLARE, gg.state_count = 2, gg.value = gv2, gg.sigma = gs2, gg.sun = gsun2;
        const ImapWindowGroup *gl[1] = {&gg};
        ImapAnnualOptions go;
        imap_annual_options_default(&go, sizeof go);
        go.window_groups = gl, go.window_group_count = 1;
        uint16_t st[4] = {9, 9, 9, 9};
        expect("the glare rule's states", imap_annual_states(sky, NULL, NULL, 1, NULL, &go, st, 4), IMAP_OK);
        for (int h = 0; h < 4; h++) {
            uint16_t want_state = 6.22e-5 * e[h] + 0.184 > 0.40;
            check("closed in the dazzling hours", st[h] == want_state, st[h], want_state);
        }
        expect("states into 3 of 4", imap_annual_states(sky, NULL, NULL, 1, NULL, &go, st, 3),
               IMAP_ERR_BUFFER_TOO_SMALL);
        ImapObserverYear shaded;
        expect("annual glare with the rule", imap_annual_glare(sky, NULL, NULL, 1, NULL, &go, &shaded, sizeof shaded),
               IMAP_OK);
        check("no hour above 0.40 once the rule closes them", shaded.hours_above[1] == 0, (double)shaded.hours_above[1], 0);
        gg.rule_dgp = 0.1;
        expect("rule_dgp 0.1", imap_annual_states(sky, NULL, NULL, 1, NULL, &go, st, 4), IMAP_ERR_INVALID_ARGUMENT);
        check("the message names it", strstr(imap_last_error(NULL), "dgp = 0.1") != NULL, 0, 0);
        gg.struct_size = offsetof(ImapWindowGroup, rule_dgp), gg.rule_dgp = 0.1;
        expect("a group of the size before rule_dgp reads 0.40", imap_annual_states(sky, NULL, NULL, 1, NULL, &go, st, 4),
               IMAP_OK);
    }

    expect("free the direct sun", imap_direct_sun_free(sun), IMAP_OK);
    expect("a freed direct sun", imap_direct_sun_hour(sun, 3, &direct, 1), IMAP_ERR_INVALID_ARGUMENT);
    expect("free it twice", imap_direct_sun_free(sun), IMAP_ERR_INVALID_ARGUMENT);
    expect("a sky given as a direct sun", imap_direct_sun_hour((ImapDirectSun *)sky, 3, &direct, 1),
           IMAP_ERR_INVALID_ARGUMENT);
    expect("free the sky", imap_annual_sky_free(sky), IMAP_OK);
    expect("a freed sky", imap_annual_sky_size(sky, &hours, &patches), IMAP_ERR_INVALID_ARGUMENT);
    expect("free NULL", imap_annual_sky_free(NULL), IMAP_OK);

    /* Bad files: named line. */
    f = fopen(path, "w");
    fputs("place x\nlatitude 48\nlongitude 0\ntime_zone 0\nsite_elevation 0\nweather_data_file_units 1\n6 31 12 0 10\n", f);
    fclose(f);
    expect("a .wea with 31 June", imap_annual_sky_read(path, 1, 0.2, &sky), IMAP_ERR_PARSE);
    check("the message names line 7", strstr(imap_last_error(NULL), ":7") != NULL, 0, 0);
    expect("no such file", imap_annual_sky_read("/nonexistent/x.epw", 1, 0.2, &sky), IMAP_ERR_IO);

    imap_destroy(ctx);

    /* Reinhart MF:2 (577 patches and the ground) in batches of light groups, in a context
     * that holds only the model: bad calls first (each leaves the context as it was), then
     * the coefficients, whose daylight factor at the open point is 1, and the direct sun
     * traced in the same context, which has no light of its own. */
    ImapContext *c2 = NULL;
    expect("imap_create (MF:2)", imap_create(&cfg, &c2), IMAP_OK);
    model(c2, &sensor_id);
    double *v2 = malloc(578 * sizeof *v2), *s2 = malloc(578 * sizeof *s2);
    uint64_t traced = 0;
    expect("MF:2 with estimator 9",
           imap_annual_trace_coefficients(c2, 2, NULL, NULL, 1000, 0, 9, sensor_id, 0, &centre, 1, v2, s2, NULL),
           IMAP_ERR_INVALID_ARGUMENT);
    expect("MF:2 with no photons and no time",
           imap_annual_trace_coefficients(c2, 2, NULL, NULL, 0, 0, 0, sensor_id, 0, &centre, 1, v2, s2, NULL),
           IMAP_ERR_INVALID_ARGUMENT);
    expect("MF:2 at vertex 5 of 5",
           imap_annual_trace_coefficients(c2, 2, NULL, NULL, 1000, 0, 0, sensor_id, 0, &bad_vertex, 1, v2, s2, NULL),
           IMAP_ERR_INDEX_OUT_OF_RANGE);
    expect("MF:2 on side 1 of a one-sided sensor",
           imap_annual_trace_coefficients(c2, 2, NULL, NULL, 1000, 0, 0, sensor_id, 1, &centre, 1, v2, s2, NULL),
           IMAP_ERR_INDEX_OUT_OF_RANGE);
    expect("MF:17", imap_annual_trace_coefficients(c2, 17, NULL, NULL, 1000, 0, 0, sensor_id, 0, &centre, 1, v2, s2, NULL),
           IMAP_ERR_INVALID_ARGUMENT);
    expect("MF:2 coefficients",
           imap_annual_trace_coefficients(c2, 2, NULL, NULL, 400000, 0, IMAP_ESTIMATOR_DEFAULT, sensor_id, 0, &centre, 1,
                                          v2, s2, &traced),
           IMAP_OK);
    check("photons traced over the three runs", traced >= 400000 && traced < 400010, (double)traced, 400000);
    expect("MF:2 daylight factor", imap_daylight_factor(v2, s2, 1, 2, 0.2, &df, &df_sigma), IMAP_OK);
    check("open point's MF:2 daylight factor is 1 (4 sigma)", fabs(df - 1) < 4 * df_sigma && df_sigma < 0.1, df, 1);
    check("no light reaches it from the ground below", v2[0] == 0, v2[0], 0);
    ImapAnnualSky *sky2 = NULL;
    f = fopen(path, "w");
    fputs(WEA, f);
    fclose(f);
    expect("MF:2 sky", imap_annual_sky_read(path, 2, 0.2, &sky2), IMAP_OK);
    expect("direct sun in a context without lights", imap_direct_sun_new(c2, sky2, pt, up, 1, NULL, NULL, 1, &sun),
           IMAP_OK);
    expect("MF:2 hourly", imap_annual_hourly(sky2, v2, s2, 1, sun, 0, 4, e, s), IMAP_OK);
    check_hours(sky2, e, s, "MF:2 ");
    expect("a second MF:2 trace in the same context",
           imap_annual_trace_coefficients(c2, 2, NULL, NULL, 2000, 0, 0, sensor_id, 0, &centre, 1, v2, s2, NULL), IMAP_OK);
    imap_direct_sun_free(sun);
    imap_annual_sky_free(sky2);
    remove(path);
    free(v2);
    free(s2);
    imap_destroy(c2);
    printf("%s\n", failures ? "FAILED" : "all passed");
    return failures ? 1 : 0;
}
