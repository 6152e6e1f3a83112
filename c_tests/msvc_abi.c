/*
 * The MSVC side of the Windows package (issue 35): a C program compiled for the
 * x86_64-pc-windows-msvc ABI (clang) and linked by lld-link against the package's imap.lib,
 * with no C runtime (kernel32 only, so that no MSVC library is needed here). It builds a
 * black 4 m × 4 m floor under a 1 W point light 1 m above its centre, runs it with light
 * sampling, and checks the flux the map puts on the floor against the light's flux into the
 * floor's solid angle, and the report's power balance. Prints one line; exit status 0 when
 * all hold.
 * scripts/test-windows.sh builds it and runs it under Wine.
 */
#include <imap.h>

/* kernel32, declared here: the program includes no Windows or C runtime header. */
__declspec(dllimport) void *__stdcall GetStdHandle(unsigned long which);
__declspec(dllimport) int __stdcall WriteFile(void *file, const void *data, unsigned long size,
                                              unsigned long *written, void *overlapped);
__declspec(dllimport) __declspec(noreturn) void __stdcall ExitProcess(unsigned int code);

/* MSVC's compiler references _fltused in any program that uses floating point; the C
   runtime defines it, and this program has none. */
int _fltused = 0;

static void say(const char *text) {
    unsigned long n = 0, written = 0;
    while (text[n]) n++;
    WriteFile(GetStdHandle((unsigned long)-11), text, n, &written, 0);
}

static void fail(const char *what) {
    say("FAIL ");
    say(what);
    say("\n");
    ExitProcess(1);
}

void start(void) {
    const char *v = imap_version();
    if (v[0] != '0' + IMAP_VERSION_MAJOR || v[1] != '.') fail("imap_version does not match the header");
    ImapConfig cfg;
    if (imap_config_default(&cfg, sizeof cfg) != IMAP_OK) fail("imap_config_default");
    cfg.threads = 2;
    cfg.seed = 11;
    ImapContext *ctx = 0;
    if (imap_create(&cfg, &ctx) != IMAP_OK) fail("imap_create");
    ImapMaterial mat;
    imap_material_default(&mat, sizeof mat);
    double black = 0;
    mat.diffuse_reflectance = &black, mat.diffuse_reflectance_count = 1;
    uint32_t m = 0, floor_id = 0, light = 0;
    if (imap_add_material(ctx, &mat, &m) != IMAP_OK) fail("imap_add_material");
    /* A 3 × 3 grid of vertices, 2 m apart, centred under the light. */
    double pos[27];
    uint32_t idx[24];
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) {
            pos[3 * (3 * j + i)] = 2.0 * i - 2, pos[3 * (3 * j + i) + 1] = 2.0 * j - 2, pos[3 * (3 * j + i) + 2] = 0;
        }
    int t = 0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            uint32_t a = (uint32_t)(3 * j + i), b = a + 1, c = a + 4, d = a + 3;
            idx[t++] = a, idx[t++] = b, idx[t++] = c, idx[t++] = a, idx[t++] = c, idx[t++] = d;
        }
    ImapMesh mesh;
    imap_mesh_default(&mesh, sizeof mesh);
    mesh.positions = pos, mesh.vertex_count = 9, mesh.indices = idx, mesh.triangle_count = 8;
    mesh.material = m, mesh.flags = IMAP_MESH_RECORD;
    if (imap_add_mesh(ctx, &mesh, &floor_id) != IMAP_OK) fail("imap_add_mesh");
    double at[3] = {0, 0, 1}, watt = 1;
    if (imap_add_point_light(ctx, at, &watt, 1, &light) != IMAP_OK) fail("imap_add_point_light");
    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.photons = 20000;
    run.estimator = IMAP_ESTIMATOR_LIGHT_SAMPLING;
    ImapReport rep;
    if (imap_run(ctx, &run, &rep, sizeof rep) != IMAP_OK) fail("imap_run");
    double e[9];
    if (imap_get_vertex_energy(ctx, floor_id, IMAP_SIDE_FRONT, 0, e, 9) != IMAP_OK) fail("imap_get_vertex_energy");
    /* The flux onto the floor, from the map (each vertex's irradiance times its share of
       the area, a third of each triangle around it), against the point light's flux into
       the floor's solid angle: Ω / 4π = atan(a b / (h √(a² + b² + h²))) / π with half sides
       a = b = 2 and h = 1, i.e. atan(4/3) / π (per band: the light's 1 W is each band's).
       The report's balance: 3 W emitted (three bands), all that lands absorbed. */
    const double share = 0.29516723530086653;
    double area[9] = {0}, flux = 0;
    for (int k = 0; k < 24; k++) area[idx[k]] += 2.0 / 3;
    for (int k = 0; k < 9; k++) {
        if (!(e[k] > 0)) fail("a vertex of the floor reads no light");
        flux += e[k] * area[k];
    }
    if (!(flux > 0.98 * share && flux < 1.02 * share)) fail("the map's flux onto the floor is not P * atan(4/3) / pi (2 %)");
    if (!(rep.emitted_w > 3 - 1e-12 && rep.emitted_w < 3 + 1e-12)) fail("the report's emitted power is not 3 W");
    if (!(rep.absorbed_w > 0.95 * 3 * share && rep.absorbed_w < 1.05 * 3 * share)) fail("the report's absorbed power is not the floor's share (5 %)");
    /* Bad input through the same import library: a specific status and a message. */
    if (imap_get_vertex_energy(ctx, floor_id, IMAP_SIDE_FRONT, 0, e, 3) != IMAP_ERR_BUFFER_TOO_SMALL) fail("a short buffer is not IMAP_ERR_BUFFER_TOO_SMALL");
    const char *msg = imap_last_error(ctx);
    if (msg == 0 || msg[0] == 0) fail("no message for a short buffer");
    if (imap_destroy(ctx) != IMAP_OK) fail("imap_destroy");
    say("msvc_abi: linked by lld-link against imap.lib; the floor's flux is P atan(4/3) / pi to 2 %; imap ");
    say(v);
    say("\n");
    ExitProcess(0);
}
