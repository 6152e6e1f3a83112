/*
 * The Cornell box rendered through libimap's C API (camera luminance by backward photon
 * maps, or final gathering from the illumination map, imap_render), written as a PFM image
 * (linear radiance, W/(m²·sr)).
 *
 *   render_cornell [out.pfm=cornell.pfm] [seconds=10] [semi|sync|async|fg] [width=256]
 *                  [height=256] [band_count=3] [target_rel_error=0]
 *
 * The camera looks through the open front of the box from (278, 273, −800) mm. It prints
 * the accuracy history and the report, and checks what physics demands, exiting non-zero
 * otherwise: a pixel that sees the lamp shows exactly its radiance M/π (a Lambertian
 * emitter of exitance M, nothing reflected); the floor is redder next to the red wall and
 * greener next to the green one (colour bleeding, carried by the forward photons or read
 * from the map); the error estimate falls; no thread ever read maps being rebuilt. With
 * fg the walls record, and the render runs the map itself.
 */
#include "cornell_scene.h"

#define PI 3.14159265358979323846

static int print_progress(const ImapProgress *p, void *user) {
    (void)user;
    printf("%10.2f %14llu %14llu %12.5f\n", p->elapsed_s, (unsigned long long)p->photons,
           (unsigned long long)p->hits, p->rel_error);
    fflush(stdout);
    return 0;
}

/* Mean of band b over the pixels whose centres see the floor region x in [x0, x1] mm,
 * z in [z0, z1] (found by intersecting the pixel's centre ray with the plane y = 0). */
static double floor_pixels(const double *rad, int bands, int b, uint32_t w, uint32_t h, const double eye[3],
                           double tan_half, double x0, double x1, double z0, double z1) {
    double sum = 0;
    int n = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            /* Camera frame: forward +z, up +y, right = forward × up = −x. */
            double sx = (2.0 * (x + 0.5) / w - 1.0) * tan_half * w / h;
            double sy = (1.0 - 2.0 * (y + 0.5) / h) * tan_half;
            double d[3] = {-sx, sy, 1.0};
            if (d[1] >= 0) continue;
            double t = -eye[1] / d[1], px = eye[0] + t * d[0], pz = eye[2] + t * d[2];
            if (px >= x0 && px <= x1 && pz >= z0 && pz <= z1) {
                sum += rad[((size_t)y * w + x) * bands + b];
                n++;
            }
        }
    return n ? sum / n : 0;
}

/* PFM: "PF", width height, −1 (little endian), float RGB rows from the bottom up. */
static int write_pfm(const char *path, const double *rad, int bands, uint32_t w, uint32_t h, const int rgb[3]) {
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    fprintf(f, "PF\n%u %u\n-1.0\n", w, h);
    for (uint32_t row = h; row-- > 0;)
        for (uint32_t x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                float v = (float)rad[((size_t)row * w + x) * bands + rgb[c]];
                fwrite(&v, sizeof v, 1, f);
            }
    return fclose(f) == 0;
}

int main(int argc, char **argv) {
    const char *out = argc > 1 ? argv[1] : "cornell.pfm";
    double seconds = argc > 2 ? atof(argv[2]) : 10.0;
    const char *method = argc > 3 ? argv[3] : "semi";
    uint32_t w = argc > 4 ? (uint32_t)atoi(argv[4]) : 256, h = argc > 5 ? (uint32_t)atoi(argv[5]) : 256;
    int bands = argc > 6 ? atoi(argv[6]) : 3;
    double target = argc > 7 ? atof(argv[7]) : 0.0;
    ImapContext *ctx = NULL;

    ImapConfig cfg;
    cornell_config(&cfg, bands);
    CHECK(imap_create(&cfg, &ctx));

    /* The box open at the front; nothing records (the photon-map methods need no
     * illumination map), except for final gathering, which reads it. */
    int fg = strcmp(method, "fg") == 0;
    Cornell box;
    cornell_build(ctx, &box, bands, 0, fg, 8);

    ImapCamera cam;
    imap_camera_default(&cam, sizeof cam);
    const double eye[3] = {278, 273, -800};
    memcpy(cam.position, eye, sizeof eye);
    cam.direction[2] = 1;
    cam.up[1] = 1;
    cam.fov_y_deg = 39.3;
    cam.width = w, cam.height = h;

    ImapRenderParams rp;
    CHECK(imap_render_params_default(&rp, sizeof rp));
    rp.method = fg                             ? IMAP_RENDER_FINAL_GATHER
                : strcmp(method, "sync") == 0  ? IMAP_RENDER_SYNC
                : strcmp(method, "async") == 0 ? IMAP_RENDER_ASYNC
                                               : IMAP_RENDER_SEMI_SYNC;
    rp.time_budget_s = seconds;
    rp.target_rel_error = target;
    rp.progress = print_progress;

    size_t pixels = (size_t)w * h;
    double *rad = malloc(pixels * (size_t)bands * sizeof(double)), *err = malloc(pixels * sizeof(double));
    if (!rad || !err) return 2;
    printf("Cornell box, %u × %u pixels, %d band%s, %s method, %.0f s\n", w, h, bands, bands == 1 ? "" : "s",
           method, seconds);
    printf("%10s %14s %14s %12s\n", "time [s]", "fwd photons", "bwd paths", "rel. error");
    ImapRenderReport rep;
    CHECK(imap_render(ctx, &cam, &rp, rad, pixels * (size_t)bands, err, pixels, &rep, sizeof rep));
    static const char *why[] = {"none", "passes", "time budget", "target error", "cancelled"};
    printf("stopped by %s after %.2f s: %.1f samples per pixel, %u threads in %u group(s)\n", why[rep.stop_reason],
           rep.wall_s, rep.passes, rep.threads, rep.groups);
    printf("backward: %llu paths (%.3f M/s), %llu rays; forward: %llu photons, %llu rays (%.3f M/s), %llu gathers\n",
           (unsigned long long)rep.backward_paths, rep.backward_paths / rep.wall_s / 1e6,
           (unsigned long long)rep.backward_rays, (unsigned long long)rep.forward_photons,
           (unsigned long long)rep.forward_rays, rep.forward_rays / rep.wall_s / 1e6, (unsigned long long)rep.gathers);
    printf("time over groups: backward %.2f s, build %.2f s, forward %.2f s, close %.2f s, finalize %.2f s; "
           "%llu joins, %llu close retries\n",
           rep.time_backward_s, rep.time_build_s, rep.time_forward_s, rep.time_close_s, rep.time_finalize_s,
           (unsigned long long)rep.joins, (unsigned long long)rep.close_retries);
    printf("memory: %.2f MB of maps per group, %.2f MB of pixel stores, %.2f MB in all; error %.4f\n",
           rep.map_bytes_per_group / 1e6, rep.pixel_bytes / 1e6, rep.total_bytes / 1e6, rep.rel_error);
    /* What this method cannot show of the scene, said plainly (the Cornell box: nothing). */
    if (rep.omitted & IMAP_RENDER_OMITS_REFRACTED_INTO_MEDIUM)
        printf("warning: light refracted into a scattering medium is missing from the picture\n");
    if (rep.omitted & IMAP_RENDER_OMITS_CAUSTICS_ON_GLOSSY)
        printf("warning: caustics on glossy surfaces are missing; final gathering shows them\n");

    int rgb[3] = {0, 1, 2};
    if (bands != 3)
        for (int c = 0; c < 3; c++) {
            double nm[3] = {650, 550, 450};
            rgb[c] = bands == 1 ? 0 : (int)lround((nm[c] - 400) / 300 * (bands - 1));
        }
    int ok = 1;
    if (!write_pfm(out, rad, bands, w, h, rgb)) {
        fprintf(stderr, "FAIL: cannot write %s\n", out);
        ok = 0;
    } else {
        printf("wrote %s\n", out);
    }

    /* The lamp's centre (278, 554.5, 279.5) seen directly: radiance M/π in every band. */
    double tan_half = tan(39.3 * PI / 360);
    double lamp[3] = {278 - eye[0], CORNELL_L - 0.5 - eye[1], 279.5 - eye[2]};
    uint32_t lx = (uint32_t)((-lamp[0] / lamp[2] / (tan_half * w / h) + 1) * 0.5 * w);
    uint32_t ly = (uint32_t)((1 - lamp[1] / lamp[2] / tan_half) * 0.5 * h);
    double le = CORNELL_LAMP_W_PER_BAND / CORNELL_LAMP_AREA_M2 / PI;
    for (int b = 0; b < bands; b++) {
        double v = rad[((size_t)ly * w + lx) * bands + b];
        if (fabs(v - le) > 1e-9 * le) {
            fprintf(stderr, "FAIL: lamp pixel (%u, %u) band %d: %.9g W/(m²·sr), expected M/π = %.9g\n", lx, ly, b, v,
                    le);
            ok = 0;
        }
    }
    printf("lamp pixel (%u, %u): %.4f W/(m²·sr) = M/π\n", lx, ly, rad[((size_t)ly * w + lx) * bands]);

    /* Colour bleeding on the floor in front of the blocks. */
    int br = rgb[0], bg = rgb[1];
    double lr = floor_pixels(rad, bands, br, w, h, eye, tan_half, 455, 545, 20, 150);
    double lg = floor_pixels(rad, bands, bg, w, h, eye, tan_half, 455, 545, 20, 150);
    double rr = floor_pixels(rad, bands, br, w, h, eye, tan_half, 10, 75, 20, 150);
    double rg = floor_pixels(rad, bands, bg, w, h, eye, tan_half, 10, 75, 20, 150);
    printf("floor next to the red wall:   R %.4f G %.4f (R/G %.3f)\n", lr, lg, lr / lg);
    printf("floor next to the green wall: R %.4f G %.4f (R/G %.3f)\n", rr, rg, rr / rg);
    if (bands > 1 && !(lr / lg > 1.1 * (rr / rg))) {
        fprintf(stderr, "FAIL: no colour bleeding on the floor\n");
        ok = 0;
    }

    /* The error estimate falls over the render; the counter protocol held. */
    size_t n_hist = 0;
    CHECK(imap_get_render_history(ctx, NULL, 0, sizeof(ImapProgress), &n_hist));
    ImapProgress *hist = malloc((n_hist ? n_hist : 1) * sizeof *hist);
    CHECK(imap_get_render_history(ctx, hist, n_hist, sizeof(ImapProgress), &n_hist));
    if (n_hist < 2 || !(hist[n_hist - 1].rel_error < hist[0].rel_error)) {
        fprintf(stderr, "FAIL: the error estimate did not fall (%zu history points)\n", n_hist);
        ok = 0;
    }
    if (rep.gate_violations != 0) {
        fprintf(stderr, "FAIL: %llu joins found maps being rebuilt\n", (unsigned long long)rep.gate_violations);
        ok = 0;
    }
    free(hist), free(rad), free(err);
    cornell_free(&box);
    imap_destroy(ctx);
    return ok ? 0 : 1;
}
