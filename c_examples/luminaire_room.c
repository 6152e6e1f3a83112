/*
 * A 6 × 4 × 3 m office lit by two luminaires read from photometric files, the way a lighting
 * program would use libimap: a recessed downlight from an IES LM-63 file and a wall washer
 * from a EULUMDAT file (the program reads the files; the library takes their text). It prints
 * the luminaires' flux, and the work plane's illuminance in lux (0.8 m above the floor, 0.25 m
 * grid): a table at 1 m spacing, and the figures EN 12464-1 asks for — the average Eavg, the
 * minimum Emin and the uniformity U0 = Emin / Eavg — each with its standard error.
 *
 * The work plane is a sensor mesh (IMAP_MESH_SENSOR): it records the light that crosses it
 * from above and changes no light path. The run stops when every point of the work plane is
 * known to `target_error` (a region target on the plane), or after `max_seconds`.
 *
 * usage: luminaire_room [downlight.ies] [wallwasher.ldt] [target_error] [max_seconds]
 *        (defaults: the files in c_examples/data, 0.02, 60)
 */
#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef IMAP_EXAMPLE_DATA
#define IMAP_EXAMPLE_DATA "data"
#endif

static void check(ImapContext *ctx, const char *what, ImapStatus s) {
    if (s != IMAP_OK) {
        fprintf(stderr, "%s: %s: %s\n", what, imap_status_name(s), imap_last_error(ctx));
        exit(1);
    }
}

/* The whole file, for the library's text functions. */
static char *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "cannot open %s\n", path);
        exit(1);
    }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    if (!buf || fread(buf, 1, (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(1);
    }
    fclose(f);
    buf[n] = '\0';
    *len = (size_t)n;
    return buf;
}

/* An axis-aligned box [lo, hi] with faces pointing inwards, as 12 triangles. */
static void room_box(const double lo[3], const double hi[3], double xyz[24], uint32_t idx[36]) {
    for (int i = 0; i < 8; i++) {
        xyz[3 * i] = (i & 1) ? hi[0] : lo[0];
        xyz[3 * i + 1] = (i & 2) ? hi[1] : lo[1];
        xyz[3 * i + 2] = (i & 4) ? hi[2] : lo[2];
    }
    /* Faces seen from inside, counter-clockwise. */
    static const uint32_t faces[36] = {0, 1, 3, 0, 3, 2, /* floor z = lo: normal +z */
                                       4, 6, 7, 4, 7, 5, /* ceiling: normal −z */
                                       0, 4, 5, 0, 5, 1, /* y = lo: normal +y */
                                       2, 3, 7, 2, 7, 6, /* y = hi: normal −y */
                                       0, 2, 6, 0, 6, 4, /* x = lo: normal +x */
                                       1, 5, 7, 1, 7, 3}; /* x = hi: normal −x */
    memcpy(idx, faces, sizeof faces);
}

int main(int argc, char **argv) {
    const char *ies_path = argc > 1 ? argv[1] : IMAP_EXAMPLE_DATA "/downlight.ies";
    const char *ldt_path = argc > 2 ? argv[2] : IMAP_EXAMPLE_DATA "/wallwasher.ldt";
    double target = argc > 3 ? atof(argv[3]) : 0.02;
    double max_s = argc > 4 ? atof(argv[4]) : 60.0;

    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    ImapContext *ctx = NULL;
    check(NULL, "imap_create", imap_create(&cfg, &ctx));

    /* Materials: walls 70 %, ceiling 80 %, floor 30 % (grey). */
    uint32_t walls, ceiling, floor_m;
    ImapMaterial m;
    double rho;
    imap_material_default(&m, sizeof m);
    m.diffuse_reflectance = &rho, m.diffuse_reflectance_count = 1;
    rho = 0.7, check(ctx, "walls", imap_add_material(ctx, &m, &walls));
    rho = 0.8, check(ctx, "ceiling", imap_add_material(ctx, &m, &ceiling));
    rho = 0.3, check(ctx, "floor", imap_add_material(ctx, &m, &floor_m));

    /* The room: one mesh, a material per face pair (floor, ceiling, 4 walls). */
    const double lo[3] = {0, 0, 0}, hi[3] = {6, 4, 3};
    double box[24];
    uint32_t box_idx[36], box_mat[12];
    room_box(lo, hi, box, box_idx);
    for (int t = 0; t < 12; t++) box_mat[t] = t < 2 ? floor_m : (t < 4 ? ceiling : walls);
    ImapMesh mesh;
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = box, mesh.vertex_count = 8, mesh.indices = box_idx, mesh.triangle_count = 12;
    mesh.triangle_materials = box_mat, mesh.material = walls;
    uint32_t room;
    check(ctx, "room", imap_add_mesh(ctx, &mesh, &room));

    /* The work plane: 0.8 m up, 0.25 m grid over the room (25 × 17 vertices), a sensor
     * recording the light from above (its front: the normal points up). */
    enum { NX = 24, NY = 16 };
    static double grid[3 * (NX + 1) * (NY + 1)];
    static uint32_t grid_idx[6 * NX * NY];
    for (int j = 0; j <= NY; j++)
        for (int i = 0; i <= NX; i++) {
            double *p = grid + 3 * (j * (NX + 1) + i);
            p[0] = 6.0 * i / NX, p[1] = 4.0 * j / NY, p[2] = 0.8;
        }
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            uint32_t a = (uint32_t)(j * (NX + 1) + i), *t = grid_idx + 6 * (j * NX + i);
            t[0] = a, t[1] = a + 1, t[2] = a + NX + 2, t[3] = a, t[4] = a + NX + 2, t[5] = a + NX + 1;
        }
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = grid, mesh.vertex_count = (NX + 1) * (NY + 1), mesh.indices = grid_idx;
    mesh.triangle_count = 2 * NX * NY, mesh.flags = IMAP_MESH_RECORD | IMAP_MESH_SENSOR;
    uint32_t plane;
    check(ctx, "work plane", imap_add_mesh(ctx, &mesh, &plane));

    /* The luminaires: a downlight in the ceiling over (2, 2), its 150 mm opening emitting;
     * a wall washer over (5, 2) aimed down with C0 towards the wall at x = 6. Warm white
     * (3000 K) and neutral white (4000 K). */
    size_t ies_len, ldt_len;
    char *ies = read_file(ies_path, &ies_len);
    char *ldt = read_file(ldt_path, &ldt_len);
    ImapLuminaire place;
    ImapSpectrum warm, neutral;
    imap_spectrum_default(&warm, sizeof warm);
    warm.kind = IMAP_SPECTRUM_BLACKBODY, warm.cct_k = 3000;
    neutral = warm, neutral.cct_k = 4000;
    imap_luminaire_default(&place, sizeof place);
    place.position[0] = 2, place.position[1] = 2, place.position[2] = 2.99;
    place.use_opening = 1;
    uint32_t downlight, washer;
    check(ctx, ies_path, imap_add_luminaire_ies(ctx, ies, ies_len, NULL, 0, &place, &warm, &downlight));
    imap_luminaire_default(&place, sizeof place);
    place.position[0] = 5, place.position[1] = 2, place.position[2] = 2.99;
    check(ctx, ldt_path, imap_add_luminaire_ldt(ctx, ldt, ldt_len, &place, &neutral, &washer));
    free(ies);
    free(ldt);
    double lm_a, lm_b;
    check(ctx, "flux", imap_get_light_flux(ctx, downlight, NULL, 0, &lm_a));
    check(ctx, "flux", imap_get_light_flux(ctx, washer, NULL, 0, &lm_b));
    printf("downlight  %-40s %7.1f lm\n", ies_path, lm_a);
    printf("wall washer %-39s %7.1f lm\n", ldt_path, lm_b);

    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.time_budget_s = max_s;
    run.region_target = target, run.region_measure = IMAP_REGION_VERTICES;
    run.region_meshes = &plane, run.region_mesh_count = 1;
    ImapReport rep;
    check(ctx, "imap_run", imap_run(ctx, &run, &rep, sizeof rep));

    enum { NV = (NX + 1) * (NY + 1) };
    static double lux[NV], err[NV], xyz[3 * NV];
    check(ctx, "lux", imap_get_vertex_illuminance(ctx, plane, IMAP_SIDE_FRONT, lux, NV));
    check(ctx, "errors", imap_get_vertex_error(ctx, plane, IMAP_SIDE_FRONT, err, NV));
    check(ctx, "xyz", imap_get_vertex_xyz(ctx, plane, IMAP_SIDE_FRONT, xyz, 3 * NV));

    printf("\nwork plane 0.8 m, illuminance in lx (x across, y down; 1 m spacing):\n      ");
    for (int i = 0; i <= NX; i += 4) printf("%7.0f", 6.0 * i / NX);
    printf("\n");
    for (int j = NY; j >= 0; j -= 4) {
        printf("%5.1f ", 4.0 * j / NY);
        for (int i = 0; i <= NX; i += 4) printf("%7.0f", lux[j * (NX + 1) + i]);
        printf("\n");
    }
    /* The region figures: Eavg from the flux crossing the plane, photon by photon (an exact
     * Monte Carlo error); Emin and U0 corrected for the bias of the minimum of noisy values. */
    ImapRegionStats st;
    check(ctx, "region", imap_get_region_stats(ctx, plane, IMAP_SIDE_FRONT, IMAP_ALL_PARTS, &st, sizeof st));
    double worst = 0, X = 0, Y = 0, Z = 0;
    for (int v = 0; v < NV; v++) {
        if (err[v] > worst) worst = err[v];
        X += xyz[3 * v], Y += xyz[3 * v + 1], Z += xyz[3 * v + 2];
    }
    double cct = 0, duv = 0, mean_xyz[3] = {X / NV, Y / NV, Z / NV};
    check(NULL, "cct", imap_xyz_to_cct(mean_xyz, &cct, &duv));
    printf("\nEavg %.1f ± %.2f lx, Emin %.1f ± %.1f lx (observed %.1f), Emax %.1f ± %.1f lx\n", st.average_lx,
           st.average_lx_sigma, st.min_lx, st.min_lx_sigma, st.min_observed_lx, st.max_lx, st.max_lx_sigma);
    printf("U0 = Emin/Eavg = %.3f ± %.3f, Ud = Emin/Emax = %.3f ± %.3f; %.1f lm on %.1f m²\n", st.u0, st.u0_sigma,
           st.ud, st.ud_sigma, st.flux_lm, st.area_m2);
    printf("colour of the light on the plane: %.0f K (Duv %+.4f)\n", cct, duv);
    printf("%llu photons in %.1f s (%s); worst point %.2f %%; %.1f lm emitted, %.1f lm absorbed\n",
           (unsigned long long)rep.photons, rep.elapsed_s,
           rep.stop_reason == IMAP_STOP_REGION_TARGET ? "work plane at its target" : "time budget", 100 * worst,
           rep.emitted_lm, rep.absorbed_lm);
    imap_destroy(ctx);
    /* Sanity for ctest: the two luminaires' light reached the plane, the run reached its
     * target, and the figures are consistent. */
    int ok = st.average_lx > 10 && st.min_lx > 0 && st.u0 > 0 && st.u0 <= 1 && st.average_lx_sigma > 0 &&
             st.average_lx_sigma < 0.02 * st.average_lx && st.min_lx <= st.average_lx && worst <= target * 1.05 &&
             rep.stop_reason == IMAP_STOP_REGION_TARGET;
    return ok ? 0 : 1;
}
