/*
 * Bad input through the C API: every mistake gets its own status and a message, and the
 * context keeps working with nothing already accumulated lost. Also checks cancel and
 * resume from the progress callback, and that the callback cannot re-enter the context.
 */
#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int failures = 0;

/* Expects `status` to be `want` and a non-empty message on `ctx` (or the thread). */
static void expect(const char *what, ImapStatus status, ImapStatus want, const ImapContext *ctx) {
    const char *msg = imap_last_error(ctx);
    if (status != want || (want != IMAP_OK && (msg == NULL || msg[0] == '\0'))) {
        printf("FAIL %-44s got %s, want %s (message: \"%s\")\n", what, imap_status_name(status), imap_status_name(want),
               msg ? msg : "(null)");
        failures++;
    } else {
        printf("ok   %-44s %s%s%s\n", what, imap_status_name(status), want != IMAP_OK ? ": " : "",
               want != IMAP_OK ? msg : "");
    }
}

/* A unit square (two triangles) at height z, facing up. */
static double square[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static uint32_t square_idx[6] = {0, 1, 2, 0, 2, 3};

static ImapMesh square_mesh(uint32_t material) {
    ImapMesh m;
    imap_mesh_default(&m, sizeof m);
    m.positions = square, m.vertex_count = 4, m.indices = square_idx, m.triangle_count = 2;
    m.material = material, m.flags = IMAP_MESH_RECORD;
    return m;
}

static ImapContext *busy_ctx;
static ImapStatus status_inside_callback;
static int cancel_after;

static int callback(const ImapProgress *p, void *user) {
    (void)p;
    int *calls = user;
    double x[4];
    status_inside_callback = imap_get_vertex_energy(busy_ctx, 0, 0, 0, x, 4);
    return ++*calls >= cancel_after;
}

int main(void) {
    ImapContext *ctx = NULL;
    ImapConfig cfg;
    uint32_t id;

    /* Creation errors are reported on the calling thread. */
    expect("imap_create(out = NULL)", imap_create(NULL, NULL), IMAP_ERR_NULL_POINTER, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.band_mode = IMAP_BANDS_SPECTRAL, cfg.band_count = 0;
    expect("spectral config with 0 bands", imap_create(&cfg, &ctx), IMAP_ERR_BAD_BANDS, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.band_count = 4;
    expect("RGB config with 4 bands", imap_create(&cfg, &ctx), IMAP_ERR_BAD_BANDS, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.unit_m = NAN;
    expect("unit_m = NaN", imap_create(&cfg, &ctx), IMAP_ERR_NON_FINITE, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.scheduler = 7;
    expect("unknown scheduler", imap_create(&cfg, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.inline_apply = 9;
    expect("unknown inline_apply", imap_create(&cfg, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.flags = 2;
    expect("unknown config flag", imap_create(&cfg, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.subd = 1;
    expect("subd = 1", imap_create(&cfg, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.initial_groups = 64, cfg.max_groups = 8;
    expect("initial_groups > max_groups", imap_create(&cfg, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    if (ctx != NULL) printf("FAIL out-parameter written on failure\n"), failures++;

    /* A zeroed struct was never initialised: refused, naming its initialiser. */
    ImapConfig zeroed;
    memset(&zeroed, 0, sizeof zeroed);
    expect("zeroed ImapConfig", imap_create(&zeroed, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    if (strstr(imap_last_error(NULL), "imap_config_default") == NULL)
        printf("FAIL zeroed ImapConfig: message does not name imap_config_default\n"), failures++;
    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 4096;
    expect("4096 threads", imap_create(&cfg, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    imap_config_default(&cfg, sizeof cfg);
    cfg.unit_m = 1e-200;
    expect("unit_m = 1e-200", imap_create(&cfg, &ctx), IMAP_ERR_INVALID_ARGUMENT, NULL);
    expect("imap_config_default(size 4)", imap_config_default(&cfg, 4), IMAP_ERR_INVALID_ARGUMENT, NULL);
    /* Any int has a static name. */
    const int odd[] = {-1, 21 + 100, 1000000, -2147483647 - 1};
    for (int i = 0; i < 4; i++)
        if (strncmp(imap_status_name(odd[i]), "IMAP_", 5) != 0)
            printf("FAIL imap_status_name(%d)\n", odd[i]), failures++;

    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 2, cfg.seed = 5;
    expect("imap_create(valid)", imap_create(&cfg, &ctx), IMAP_OK, ctx);
    busy_ctx = ctx;

    /* Run before any mesh. */
    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.photons = 20000;
    expect("run before any mesh", imap_run(ctx, &run, NULL, 0), IMAP_ERR_NO_GEOMETRY, ctx);

    /* Materials. */
    double grey = 0.5, too_much = 1.5, two[2] = {0.1, 0.2};
    ImapMaterial mat;
    imap_material_default(&mat, sizeof mat);
    mat.diffuse_reflectance = &too_much, mat.diffuse_reflectance_count = 1;
    expect("reflectance 1.5", imap_add_material(ctx, &mat, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    mat.diffuse_reflectance = two, mat.diffuse_reflectance_count = 2;
    expect("2 reflectances for 3 bands", imap_add_material(ctx, &mat, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    mat.diffuse_reflectance = NULL, mat.diffuse_reflectance_count = 1;
    expect("reflectance NULL with count 1", imap_add_material(ctx, &mat, &id), IMAP_ERR_NULL_POINTER, ctx);
    mat.diffuse_reflectance = &grey;
    expect("imap_add_material(NULL ctx)", imap_add_material(NULL, &mat, &id), IMAP_ERR_NULL_POINTER, NULL);
    uint32_t m_grey = 99;
    expect("imap_add_material(valid)", imap_add_material(ctx, &mat, &m_grey), IMAP_OK, ctx);

    /* Rough surfaces. */
    ImapMaterial rough;
    imap_material_default(&rough, sizeof rough);
    rough.surface = IMAP_SURFACE_CONDUCTOR, rough.metal = IMAP_METAL_GOLD;
    expect("conductor without roughness", imap_add_material(ctx, &rough, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    rough.roughness[0] = -0.2;
    expect("negative roughness", imap_add_material(ctx, &rough, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    rough.roughness[0] = NAN;
    expect("NaN roughness", imap_add_material(ctx, &rough, &id), IMAP_ERR_NON_FINITE, ctx);
    rough.roughness[0] = 0.3;
    rough.metal = 17;
    expect("unknown metal", imap_add_material(ctx, &rough, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    double nk[6] = {500, 1.0, 2.0, 600, 1.0, 2.0};
    rough.metal = IMAP_METAL_CUSTOM, rough.conductor_nk = nk, rough.conductor_nk_count = 2;
    expect("n, k table not covering the bands", imap_add_material(ctx, &rough, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    rough.conductor_nk = NULL;
    expect("n, k table NULL", imap_add_material(ctx, &rough, &id), IMAP_ERR_NULL_POINTER, ctx);
    rough.conductor_nk_count = 0, rough.surface = 9;
    expect("unknown surface", imap_add_material(ctx, &rough, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    rough.surface = IMAP_SURFACE_PLASTIC;
    expect("plastic without a coat index", imap_add_material(ctx, &rough, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    rough.ior_model = IMAP_IOR_CONSTANT, rough.ior[0] = 1.5, rough.diffuse_reflectance = &grey;
    rough.diffuse_reflectance_count = 1;
    expect("plastic (valid)", imap_add_material(ctx, &rough, &id), IMAP_OK, ctx);
    rough.surface = IMAP_SURFACE_CONDUCTOR, rough.metal = IMAP_METAL_ALUMINIUM;
    expect("conductor with a diffuse reflectance", imap_add_material(ctx, &rough, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    rough.diffuse_reflectance = NULL, rough.diffuse_reflectance_count = 0, rough.ior_model = IMAP_IOR_NONE;
    rough.flags = 4;
    expect("unknown material flag", imap_add_material(ctx, &rough, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    rough.flags = IMAP_MATERIAL_SINGLE_SCATTERING;
    expect("conductor, single scattering (valid)", imap_add_material(ctx, &rough, &id), IMAP_OK, ctx);
    rough.flags = 0;
    expect("conductor (valid)", imap_add_material(ctx, &rough, &id), IMAP_OK, ctx);
    double recip = -1, alb = -1;
    expect("table check of a conductor", imap_get_table_check(ctx, id, &recip, &alb), IMAP_ERR_INVALID_ARGUMENT, ctx);

    /* A scattering medium with a tabulated phase function. */
    ImapMaterial haze;
    imap_material_default(&haze, sizeof haze);
    double sig = 5, ang[3] = {0, 90, 180}, val[3] = {3, 1, 1};
    haze.ior_model = IMAP_IOR_CONSTANT, haze.ior[0] = 1.0;
    haze.scattering_per_m = &sig, haze.scattering_count = 1;
    haze.phase_angles_deg = ang, haze.phase_values = NULL, haze.phase_table_count = 3;
    expect("phase table values NULL", imap_add_material(ctx, &haze, &id), IMAP_ERR_NULL_POINTER, ctx);
    haze.phase_values = val, ang[2] = 170;
    expect("phase table ending at 170 degrees", imap_add_material(ctx, &haze, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    ang[2] = 180;
    expect("phase table (valid)", imap_add_material(ctx, &haze, &id), IMAP_OK, ctx);
    /* The scene's medium: a medium of index 1 only; IMAP_NO_MEDIUM empties it again. */
    expect("scene medium of a grey surface", imap_set_scene_medium(ctx, m_grey), IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("scene medium of material 999", imap_set_scene_medium(ctx, 999), IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("scene medium (valid)", imap_set_scene_medium(ctx, id), IMAP_OK, ctx);
    expect("no scene medium (valid)", imap_set_scene_medium(ctx, IMAP_NO_MEDIUM), IMAP_OK, ctx);
    expect("scene medium on NULL", imap_set_scene_medium(NULL, id), IMAP_ERR_NULL_POINTER, NULL);

    /* Fluorescence in an RGB context: refused, RGB has no wavelengths to shift between. */
    ImapMaterial fl;
    imap_material_default(&fl, sizeof fl);
    double shares[9] = {0, 0.2, 0, 0, 0, 0, 0, 0, 0};
    fl.fluorescence = shares, fl.fluorescence_count = 9;
    expect("fluorescence in RGB", imap_add_material(ctx, &fl, &id), IMAP_ERR_UNSUPPORTED, ctx);
    fl.fluorescence = NULL;
    expect("fluorescence NULL", imap_add_material(ctx, &fl, &id), IMAP_ERR_NULL_POINTER, ctx);

    /* Fluorescent media, in a spectral context of 3 bands (380, 580, 780 nm): a medium
     * re-emits what it absorbs, so it must absorb; the scene's medium may not fluoresce;
     * a microfacet surface has no fluorescence to give. The context stays usable. */
    {
        ImapConfig scfg;
        imap_config_default(&scfg, sizeof scfg);
        scfg.band_mode = IMAP_BANDS_SPECTRAL, scfg.band_count = 3;
        ImapContext *sctx = NULL;
        expect("spectral context (valid)", imap_create(&scfg, &sctx), IMAP_OK, NULL);
        ImapMaterial fm;
        imap_material_default(&fm, sizeof fm);
        fm.ior_model = IMAP_IOR_CONSTANT, fm.ior[0] = 1.0;
        fm.fluorescence = shares, fm.fluorescence_count = 9;
        expect("fluorescent medium that absorbs nothing", imap_add_material(sctx, &fm, &id),
               IMAP_ERR_BAD_MATERIAL, sctx);
        double absorbs[3] = {5, 0, 0};
        fm.absorption_per_m = absorbs, fm.absorption_count = 3;
        uint32_t glowing;
        expect("fluorescent medium (valid)", imap_add_material(sctx, &fm, &glowing), IMAP_OK, sctx);
        expect("fluorescent scene medium", imap_set_scene_medium(sctx, glowing), IMAP_ERR_UNSUPPORTED, sctx);
        ImapMaterial pl;
        imap_material_default(&pl, sizeof pl);
        pl.surface = IMAP_SURFACE_PLASTIC, pl.roughness[0] = 0.2;
        pl.fluorescence = shares, pl.fluorescence_count = 9;
        expect("fluorescent plastic", imap_add_material(sctx, &pl, &id), IMAP_ERR_BAD_MATERIAL, sctx);
        imap_destroy(sctx);
    }

    /* Measured tables: 3 incident and 4 outgoing polar angles, 6 outgoing azimuths. */
    double lambert_table[3 * 4 * 6];
    for (int i = 0; i < 3 * 4 * 6; i++) lambert_table[i] = 0.5 / 3.14159265358979;
    ImapMaterial tab;
    imap_material_default(&tab, sizeof tab);
    tab.surface = IMAP_SURFACE_TABLE;
    tab.table_theta_in_count = 3, tab.table_phi_in_count = 1, tab.table_theta_out_count = 4;
    tab.table_phi_out_count = 6, tab.table_brdf = lambert_table, tab.table_brdf_count = 3 * 4 * 6 - 1;
    expect("table of the wrong size", imap_add_material(ctx, &tab, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    tab.table_brdf_count = 3 * 4 * 6;
    lambert_table[5] = NAN;
    expect("table holding a NaN", imap_add_material(ctx, &tab, &id), IMAP_ERR_NON_FINITE, ctx);
    /* f = 1/sr at normal incidence: albedo π. */
    for (int i = 0; i < 4 * 6; i++) lambert_table[i] = 1.0;
    expect("table reflecting more than it receives", imap_add_material(ctx, &tab, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    for (int i = 0; i < 4 * 6; i++) lambert_table[i] = 0.5 / 3.14159265358979;
    tab.roughness[0] = 0.2;
    expect("table with a roughness", imap_add_material(ctx, &tab, &id), IMAP_ERR_BAD_MATERIAL, ctx);
    tab.roughness[0] = 0;
    expect("table (valid)", imap_add_material(ctx, &tab, &id), IMAP_OK, ctx);
    expect("table check", imap_get_table_check(ctx, id, &recip, &alb), IMAP_OK, ctx);
    if (!(recip < 1e-12 && alb > 0.49 && alb < 0.51)) {
        fprintf(stderr, "FAIL: Lambertian table check: reciprocity %g, albedo %g\n", recip, alb);
        failures++;
    }
    expect("table check of material 999", imap_get_table_check(ctx, 999, &recip, &alb), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);

    /* Window BSDF files. */
    ImapMaterial xml;
    imap_material_default(&xml, sizeof xml);
    xml.surface = IMAP_SURFACE_BSDF_XML;
    expect("BSDF file path NULL", imap_add_material(ctx, &xml, &id), IMAP_ERR_NULL_POINTER, ctx);
    xml.bsdf_xml_path = "/nonexistent/blind.xml";
    expect("BSDF file missing", imap_add_material(ctx, &xml, &id), IMAP_ERR_IO, ctx);
    char xml_path[64];
    snprintf(xml_path, sizeof xml_path, "/tmp/imap-bad-input-%ld.xml", (long)time(NULL));
    const char *head =
        "<?xml version=\"1.0\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical><Layer>\n"
        "<DataDefinition><IncidentDataStructure>%s</IncidentDataStructure></DataDefinition>\n"
        "<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength>\n"
        "<WavelengthDataBlock><WavelengthDataDirection>Transmission Front</WavelengthDataDirection>\n"
        "<ColumnAngleBasis>LBNL/Klems Quarter</ColumnAngleBasis><RowAngleBasis>LBNL/Klems Quarter</RowAngleBasis>\n"
        "<ScatteringData>\n";
    for (int variant = 0; variant < 3; variant++) {
        FILE *f = fopen(xml_path, "w");
        if (!f) { fprintf(stderr, "FAIL: cannot write %s\n", xml_path); failures++; break; }
        fprintf(f, head, variant == 1 ? "TensorTree3" : "Columns");
        /* A diffuse transmitter: 0.4 / pi from every patch to every patch (41 x 41). */
        for (int i = 0; i < 41 * 41 - (variant == 2); i++) fprintf(f, "%.9f,%c", 0.4 / 3.14159265358979, i % 41 == 40 ? '\n' : ' ');
        fprintf(f, "</ScatteringData></WavelengthDataBlock></WavelengthData></Layer></Optical></WindowElement>\n");
        fclose(f);
        xml.bsdf_xml_path = xml_path;
        ImapStatus want = variant == 0 ? IMAP_OK : variant == 1 ? IMAP_ERR_UNSUPPORTED : IMAP_ERR_PARSE;
        const char *what = variant == 0 ? "BSDF file (valid)" : variant == 1 ? "tensor-tree BSDF file" : "BSDF file one value short";
        expect(what, imap_add_material(ctx, &xml, &id), want, ctx);
        if (variant == 2 && !strstr(imap_last_error(ctx), xml_path)) {
            fprintf(stderr, "FAIL: the short file's message does not name it: %s\n", imap_last_error(ctx));
            failures++;
        }
        if (variant == 0) {
            expect("BSDF file check", imap_get_table_check(ctx, id, &recip, &alb), IMAP_OK, ctx);
            if (!(recip < 1e-9 && alb > 0.399 && alb < 0.401)) {
                fprintf(stderr, "FAIL: diffuse BSDF file check: reciprocity %g, albedo %g\n", recip, alb);
                failures++;
            }
        }
    }
    remove(xml_path);
    xml.surface = IMAP_SURFACE_IDEAL;
    expect("BSDF file path on an ideal surface", imap_add_material(ctx, &xml, &id), IMAP_ERR_BAD_MATERIAL, ctx);

    /* Textures and per-vertex factors (in a context of their own). */
    ImapContext *tctx = NULL;
    ImapConfig tcfg;
    imap_config_default(&tcfg, sizeof tcfg);
    expect("texture context", imap_create(&tcfg, &tctx), IMAP_OK, NULL);
    double texels[4] = {1.0, 0.5, 0.25, 1.5};
    ImapTexture tex;
    imap_texture_default(&tex, sizeof tex);
    tex.width = 2, tex.height = 2, tex.channels = 1, tex.values = texels, tex.value_count = 4;
    expect("texture value above 1", imap_add_texture(tctx, &tex, &id), IMAP_ERR_INVALID_ARGUMENT, tctx);
    texels[3] = 0.75;
    tex.value_count = 3;
    expect("texture of the wrong size", imap_add_texture(tctx, &tex, &id), IMAP_ERR_INVALID_ARGUMENT, tctx);
    tex.value_count = 4, tex.channels = 2;
    expect("texture of 2 channels", imap_add_texture(tctx, &tex, &id), IMAP_ERR_INVALID_ARGUMENT, tctx);
    tex.channels = 1, tex.flags = 64;
    expect("unknown texture flag", imap_add_texture(tctx, &tex, &id), IMAP_ERR_INVALID_ARGUMENT, tctx);
    tex.flags = IMAP_TEXTURE_NEAREST;
    uint32_t tex_id;
    expect("texture (valid)", imap_add_texture(tctx, &tex, &tex_id), IMAP_OK, tctx);
    ImapMaterial tm;
    imap_material_default(&tm, sizeof tm);
    double half = 0.5;
    tm.diffuse_reflectance = &half, tm.diffuse_reflectance_count = 1;
    tm.texture = tex_id + 9;
    expect("material naming a missing texture", imap_add_material(tctx, &tm, &id), IMAP_ERR_INDEX_OUT_OF_RANGE, tctx);
    tm.texture = tex_id, tm.texture_lobes = 16;
    expect("unknown texture lobe", imap_add_material(tctx, &tm, &id), IMAP_ERR_INVALID_ARGUMENT, tctx);
    tm.texture_lobes = IMAP_LOBE_ROUGHNESS;
    expect("roughness texture on a Lambertian surface", imap_add_material(tctx, &tm, &id), IMAP_ERR_BAD_MATERIAL, tctx);
    tm.texture_lobes = 0, tm.flags = IMAP_MATERIAL_TANGENT_FROM_UVS;
    expect("tangent from uvs on a Lambertian surface", imap_add_material(tctx, &tm, &id), IMAP_ERR_BAD_MATERIAL, tctx);
    tm.flags = 0;
    ImapMaterial metal;
    imap_material_default(&metal, sizeof metal);
    metal.surface = IMAP_SURFACE_CONDUCTOR, metal.metal = IMAP_METAL_ALUMINIUM;
    metal.roughness[0] = 0.1, metal.roughness[1] = 0.4;
    metal.texture = tex_id, metal.texture_lobes = IMAP_LOBE_ROUGHNESS;
    expect("roughness texture on anisotropic roughness", imap_add_material(tctx, &metal, &id), IMAP_ERR_UNSUPPORTED, tctx);
    metal.roughness[1] = 0, metal.texture_lobes = IMAP_LOBE_ROUGHNESS | IMAP_LOBE_SPECULAR_REFLECTION;
    metal.flags = IMAP_MATERIAL_TANGENT_FROM_UVS;
    expect("textured rough metal (valid)", imap_add_material(tctx, &metal, &id), IMAP_OK, tctx);
    tm.texture_lobes = IMAP_LOBE_DIFFUSE_REFLECTION;
    uint32_t m_tex;
    expect("textured material (valid)", imap_add_material(tctx, &tm, &m_tex), IMAP_OK, tctx);
    ImapMesh tmesh = square_mesh(m_tex);
    expect("textured mesh without uvs", imap_add_mesh(tctx, &tmesh, &id), IMAP_ERR_INVALID_ARGUMENT, tctx);
    double uvs[8] = {0, 0, 1, 0, 1, 1, 0, 1}, factors[4] = {1, 0.5, NAN, 1};
    tmesh.uvs = uvs;
    tmesh.vertex_factors = factors;
    expect("vertex factor NaN", imap_add_mesh(tctx, &tmesh, &id), IMAP_ERR_NON_FINITE, tctx);
    factors[2] = 0.25;
    tmesh.vertex_factor_channels = 5;
    expect("vertex factors of 5 channels", imap_add_mesh(tctx, &tmesh, &id), IMAP_ERR_INVALID_ARGUMENT, tctx);
    tmesh.vertex_factor_channels = 1;
    expect("textured mesh with factors (valid)", imap_add_mesh(tctx, &tmesh, &id), IMAP_OK, tctx);
    imap_destroy(tctx);

    /* Meshes. */
    ImapMesh mesh = square_mesh(m_grey);
    expect("imap_add_mesh(mesh = NULL)", imap_add_mesh(ctx, NULL, &id), IMAP_ERR_NULL_POINTER, ctx);
    mesh.positions = NULL;
    expect("positions NULL", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_NULL_POINTER, ctx);
    mesh = square_mesh(m_grey);
    square[4] = NAN;
    expect("NaN coordinate", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_NON_FINITE, ctx);
    square[4] = INFINITY;
    expect("Inf coordinate", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_NON_FINITE, ctx);
    square[4] = 0;
    square_idx[5] = 4;
    expect("vertex index out of range", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    square_idx[5] = 0;
    expect("triangle repeating a vertex", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_DEGENERATE_TRIANGLE, ctx);
    mesh.flags = IMAP_MESH_SKIP_DEGENERATE;
    mesh.triangle_count = 1;
    square_idx[2] = 1;
    expect("only degenerate triangles, skipped", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_DEGENERATE_TRIANGLE, ctx);
    square_idx[2] = 2;
    mesh = square_mesh(m_grey);
    square_idx[5] = 3;
    mesh.triangle_count = 0;
    expect("mesh with zero triangles", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_EMPTY_MESH, ctx);
    mesh = square_mesh(7);
    expect("unknown material id", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_UNKNOWN_MATERIAL, ctx);
    mesh = square_mesh(m_grey);
    uint32_t floor_id = 99;
    expect("imap_add_mesh(valid)", imap_add_mesh(ctx, &mesh, &floor_id), IMAP_OK, ctx);
    size_t dropped = 99;
    expect("imap_get_mesh_dropped_triangles", imap_get_mesh_dropped_triangles(ctx, floor_id, &dropped), IMAP_OK, ctx);
    if (dropped != 0) {
        fprintf(stderr, "FAIL: %zu triangles dropped from a clean mesh\n", dropped);
        failures++;
    }
    expect("imap_get_mesh_dropped_triangles(out = NULL)", imap_get_mesh_dropped_triangles(ctx, floor_id, NULL),
           IMAP_ERR_NULL_POINTER, ctx);
    expect("imap_get_mesh_dropped_triangles(mesh 99)", imap_get_mesh_dropped_triangles(ctx, 99, &dropped),
           IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);

    /* Lights. */
    double pos[3] = {0.5, 0.5, 1}, zero = 0, watts = 10, nan_pos[3] = {0, NAN, 1};
    expect("run with no light", imap_run(ctx, &run, NULL, 0), IMAP_ERR_NO_LIGHT, ctx);
    expect("zero-power light", imap_add_point_light(ctx, pos, &zero, 1, &id), IMAP_ERR_NO_LIGHT, ctx);
    expect("light at NaN", imap_add_point_light(ctx, nan_pos, &watts, 1, &id), IMAP_ERR_NON_FINITE, ctx);
    expect("light out_id = NULL", imap_add_point_light(ctx, pos, &watts, 1, NULL), IMAP_ERR_NULL_POINTER, ctx);
    expect("imap_add_point_light(valid)", imap_add_point_light(ctx, pos, &watts, 1, &id), IMAP_OK, ctx);

    /* Run parameters. */
    ImapRunParams none;
    imap_run_params_default(&none, sizeof none);
    expect("run without a stop criterion", imap_run(ctx, &none, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    none.photons = 1000, none.time_budget_s = -1;
    expect("negative time budget", imap_run(ctx, &none, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);

    /* A real run, then read-backs with bad arguments. */
    ImapReport rep;
    expect("imap_run(valid)", imap_run(ctx, &run, &rep, sizeof rep), IMAP_OK, ctx);
    double before[4], after[4], err[4];
    expect("read back", imap_get_vertex_energy(ctx, floor_id, IMAP_SIDE_FRONT, 1, before, 4), IMAP_OK, ctx);
    expect("band 3 of 3", imap_get_vertex_energy(ctx, floor_id, 0, 3, after, 4), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    expect("back side of a one-sided mesh", imap_get_vertex_energy(ctx, floor_id, IMAP_SIDE_BACK, 0, after, 4),
           IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    expect("mesh id 5", imap_get_vertex_energy(ctx, 5, 0, 0, after, 4), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    expect("output of 3 for 4 vertices", imap_get_vertex_energy(ctx, floor_id, 0, 0, after, 3), IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    expect("output NULL", imap_get_vertex_error(ctx, floor_id, 0, NULL, 4), IMAP_ERR_NULL_POINTER, ctx);
    /* Region figures and region targets. */
    ImapRegionStats rs;
    expect("region stats", imap_get_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, &rs, sizeof rs), IMAP_OK, ctx);
    if (!(rs.area_m2 > 0 && rs.vertices == 4 && rs.photons > 0 && rs.average_lx > 0 && rs.average_lx_sigma > 0 &&
          rs.u0 > 0 && rs.u0 <= 1.5))
        printf("FAIL region stats: area %g, %u vertices, Eavg %g ± %g, U0 %g\n", rs.area_m2, rs.vertices,
               rs.average_lx, rs.average_lx_sigma, rs.u0), failures++;
    expect("region stats of size 4", imap_get_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, &rs, 4),
           IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("region stats out NULL", imap_get_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, NULL, sizeof rs),
           IMAP_ERR_NULL_POINTER, ctx);
    expect("region of a material the mesh lacks", imap_get_region_stats(ctx, floor_id, 0, 77, &rs, sizeof rs),
           IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    expect("region of back side", imap_get_region_stats(ctx, floor_id, 1, IMAP_ALL_PARTS, &rs, sizeof rs),
           IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    double bf[6];
    expect("region band flux of 5 for 3 bands", imap_get_region_band_flux(ctx, floor_id, 0, IMAP_ALL_PARTS, bf, 5),
           IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    expect("medium absorbed by a floor, which holds none", imap_get_medium_absorbed(ctx, floor_id, bf, 6),
           IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("medium absorbed by mesh 999", imap_get_medium_absorbed(ctx, 999, bf, 6), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    expect("scene medium absorbed without one", imap_get_medium_absorbed(ctx, IMAP_SCENE_MEDIUM, bf, 6),
           IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("medium absorbed into NULL", imap_get_medium_absorbed(ctx, floor_id, NULL, 6), IMAP_ERR_NULL_POINTER, ctx);
    expect("vertex areas of 3 for 4 vertices", imap_get_vertex_areas(ctx, floor_id, after, 3), IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    ImapRunParams rt;
    imap_run_params_default(&rt, sizeof rt);
    uint32_t rmesh = floor_id;
    rt.region_target = 0.5, rt.region_meshes = &rmesh, rt.region_mesh_count = 1;
    rt.region_measure = 3;
    expect("region measure 3", imap_run(ctx, &rt, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    rt.region_measure = IMAP_REGION_VERTICES, rt.region_percentile = 101;
    expect("region percentile 101", imap_run(ctx, &rt, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    rt.region_percentile = 0, rt.region_meshes = NULL;
    expect("region meshes NULL", imap_run(ctx, &rt, NULL, 0), IMAP_ERR_NULL_POINTER, ctx);
    rmesh = 9, rt.region_meshes = &rmesh;
    expect("region mesh 9", imap_run(ctx, &rt, NULL, 0), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    rmesh = floor_id, rt.region_target = -1;
    expect("negative region target", imap_run(ctx, &rt, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    mesh = square_mesh(m_grey);
    expect("mesh added after a run", imap_add_mesh(ctx, &mesh, &id), IMAP_ERR_OUT_OF_ORDER, ctx);
    expect("light added after a run", imap_add_point_light(ctx, pos, &watts, 1, &id), IMAP_ERR_OUT_OF_ORDER, ctx);
    /* Layers: unknown flags, changes after a run, layers that are not kept. */
    expect("layer flags 4", imap_set_layers(ctx, 4), IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("layers asked for after a run", imap_set_layers(ctx, IMAP_KEEP_DIRECT), IMAP_ERR_OUT_OF_ORDER, ctx);
    expect("light group set after a run", imap_set_light_group(ctx, 0, 1), IMAP_ERR_OUT_OF_ORDER, ctx);
    expect("group layer not kept", imap_get_layer_energy(ctx, floor_id, 0, 1, 0, after, 4), IMAP_ERR_NOT_RECORDED, ctx);
    expect("direct layer not kept", imap_get_layer_error(ctx, floor_id, 0, IMAP_LAYER_DIRECT, after, 4),
           IMAP_ERR_NOT_RECORDED, ctx);
    expect("layers, NULL outputs", imap_get_layers(ctx, NULL, NULL), IMAP_OK, ctx);
    expect("IMAP_LAYER_ALL", imap_get_layer_energy(ctx, floor_id, 0, 1, IMAP_LAYER_ALL, after, 4), IMAP_OK, ctx);
    if (memcmp(before, after, sizeof before) != 0) printf("FAIL IMAP_LAYER_ALL differs from the map\n"), failures++;

    /* Render: bad cameras and parameters refused before any work, then a real render,
     * which leaves the illumination map as it was. */
    ImapRenderReport rr;
    expect("render report before any render", imap_get_render_report(ctx, &rr, sizeof rr), IMAP_ERR_OUT_OF_ORDER, ctx);
    ImapCamera cam;
    imap_camera_default(&cam, sizeof cam);
    cam.position[0] = 0.5, cam.position[1] = 0.5, cam.position[2] = 0.9;
    cam.direction[2] = -1, cam.up[1] = 1, cam.fov_y_deg = 60, cam.width = 8, cam.height = 8;
    ImapRenderParams rp;
    expect("imap_render_params_default", imap_render_params_default(&rp, sizeof rp), IMAP_OK, NULL);
    rp.passes = 4;
    double img[8 * 8 * 3], img_err[8 * 8];
    expect("camera NULL", imap_render(ctx, NULL, &rp, img, 192, NULL, 0, NULL, 0), IMAP_ERR_NULL_POINTER, ctx);
    expect("params NULL", imap_render(ctx, &cam, NULL, img, 192, NULL, 0, NULL, 0), IMAP_ERR_NULL_POINTER, ctx);
    expect("radiance buffer NULL", imap_render(ctx, &cam, &rp, NULL, 192, NULL, 0, NULL, 0), IMAP_ERR_NULL_POINTER, ctx);
    expect("radiance buffer of 191 for 8 × 8 × 3", imap_render(ctx, &cam, &rp, img, 191, NULL, 0, NULL, 0),
           IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    expect("error buffer of 63 for 8 × 8", imap_render(ctx, &cam, &rp, img, 192, img_err, 63, NULL, 0),
           IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    rp.method = 7;
    expect("render method 7", imap_render(ctx, &cam, &rp, img, 192, NULL, 0, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    rp.method = IMAP_RENDER_SEMI_SYNC, rp.alpha = 1.5;
    expect("alpha 1.5", imap_render(ctx, &cam, &rp, img, 192, NULL, 0, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    rp.alpha = 0, rp.passes = 0;
    expect("render without a stop criterion", imap_render(ctx, &cam, &rp, img, 192, NULL, 0, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT, ctx);
    rp.passes = 4;
    cam.fov_y_deg = 180;
    expect("field of view 180°", imap_render(ctx, &cam, &rp, img, 192, NULL, 0, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    cam.fov_y_deg = 60, cam.up[1] = 0, cam.up[2] = 1;
    expect("up parallel to the view", imap_render(ctx, &cam, &rp, img, 192, NULL, 0, NULL, 0), IMAP_ERR_INVALID_ARGUMENT,
           ctx);
    cam.up[1] = 1, cam.up[2] = 0, cam.position[0] = NAN;
    expect("camera at NaN", imap_render(ctx, &cam, &rp, img, 192, NULL, 0, NULL, 0), IMAP_ERR_NON_FINITE, ctx);
    cam.position[0] = 0.5, cam.width = 0;
    expect("image width 0", imap_render(ctx, &cam, &rp, img, 192, NULL, 0, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    cam.width = 8;
    expect("imap_render(valid)", imap_render(ctx, &cam, &rp, img, 192, img_err, 64, &rr, sizeof rr), IMAP_OK, ctx);
    /* The pixel looking straight down at the floor under the light: ρE/π, E = I/h². */
    double centre = 0.5 * 10 / (4 * 3.14159265358979) / 3.14159265358979;
    if (!(rr.passes >= 4 && rr.gate_violations == 0 && fabs(img[(4 * 8 + 4) * 3] / centre - 1) < 0.1))
        printf("FAIL render: %.1f passes, %llu violations, centre pixel %g want about %g\n", rr.passes,
               (unsigned long long)rr.gate_violations, img[(4 * 8 + 4) * 3], centre), failures++;
    size_t hist_len = 0;
    expect("render history length", imap_get_render_history(ctx, NULL, 0, sizeof(ImapProgress), &hist_len), IMAP_OK, ctx);
    if (hist_len == 0 || hist_len != rr.history_len) printf("FAIL render history of %zu points\n", hist_len), failures++;

    /* A render cancelled from its callback on the 2nd call: it stops, says why, keeps
     * its image, and the callback could not re-enter the context. */
    int render_calls = 0;
    cancel_after = 2;
    status_inside_callback = IMAP_OK;
    ImapRenderParams rc;
    imap_render_params_default(&rc, sizeof rc);
    rc.progress = callback, rc.user_data = &render_calls, rc.progress_interval_s = 0.02;
    expect("render cancelled from the callback", imap_render(ctx, &cam, &rc, img, 192, NULL, 0, &rr, sizeof rr), IMAP_OK, ctx);
    if (rr.stop_reason != IMAP_STOP_CANCELLED || !(rr.passes > 0))
        printf("FAIL render stop_reason %u after %.1f passes, want CANCELLED\n", rr.stop_reason, rr.passes), failures++;
    expect("callback re-entering the context during a render", status_inside_callback, IMAP_ERR_BUSY, ctx);

    /* Nothing accumulated was lost through all those errors. */
    imap_get_vertex_energy(ctx, floor_id, IMAP_SIDE_FRONT, 1, after, 4);
    if (memcmp(before, after, sizeof before) != 0 || !(before[0] > 0)) printf("FAIL map changed by failing calls\n"), failures++;

    /* Cancel from the callback on its 2nd call, then resume: the photon count adds up and
     * the callback could not re-enter the context. */
    int calls = 0;
    cancel_after = 2;
    ImapRunParams cb;
    imap_run_params_default(&cb, sizeof cb);
    cb.progress = callback, cb.user_data = &calls, cb.progress_interval_s = 0.05;
    ImapReport r1, r2;
    expect("run cancelled from the callback", imap_run(ctx, &cb, &r1, sizeof r1), IMAP_OK, ctx);
    if (r1.stop_reason != IMAP_STOP_CANCELLED) printf("FAIL stop_reason %u, want CANCELLED\n", r1.stop_reason), failures++;
    expect("callback re-entering the context", status_inside_callback, IMAP_ERR_BUSY, ctx);
    run.photons = 30000;
    expect("resumed run", imap_run(ctx, &run, &r2, sizeof r2), IMAP_OK, ctx);
    if (r2.photons != r1.photons + 30000 || r1.photons != rep.photons + r1.run_photons)
        printf("FAIL photons do not add up: %llu, %llu, %llu\n", (unsigned long long)rep.photons,
               (unsigned long long)r1.photons, (unsigned long long)r2.photons), failures++;
    expect("errors after all that", imap_get_vertex_error(ctx, floor_id, 0, err, 4), IMAP_OK, ctx);
    for (int i = 0; i < 4; i++)
        if (!(err[i] > 0 && err[i] < 0.2)) printf("FAIL vertex %d relative error %g\n", i, err[i]), failures++;

    /* Final gathering reads and extends the map: 2000 photons before each of 3 passes
     * beyond what it holds. A forward_per_pass below what the map holds adds none. */
    ImapRenderParams fg;
    imap_render_params_default(&fg, sizeof fg);
    fg.method = IMAP_RENDER_FINAL_GATHER, fg.passes = 3, fg.forward_per_pass = r2.photons + 2000;
    expect("final gathering", imap_render(ctx, &cam, &fg, img, 192, img_err, 64, &rr, sizeof rr), IMAP_OK, ctx);
    ImapReport r3;
    imap_get_report(ctx, &r3, sizeof r3);
    if (rr.forward_photons != r3.photons - r2.photons || r3.photons != 3 * (r2.photons + 2000) || rr.passes != 3 ||
        !(fabs(img[(4 * 8 + 4) * 3] / centre - 1) < 0.1))
        printf("FAIL final gathering: %.1f passes, map %llu -> %llu photons, centre pixel %g want about %g\n", rr.passes,
               (unsigned long long)r2.photons, (unsigned long long)r3.photons, img[(4 * 8 + 4) * 3], centre),
            failures++;
    fg.forward_per_pass = 1;
    expect("final gathering on the map as it is", imap_render(ctx, &cam, &fg, img, 192, NULL, 0, &rr, sizeof rr), IMAP_OK,
           ctx);
    if (rr.forward_photons != 0) printf("FAIL final gathering added %llu photons\n", (unsigned long long)rr.forward_photons), failures++;

    /* Reset unlocks the scene. */
    expect("imap_reset", imap_reset(ctx), IMAP_OK, ctx);
    expect("mesh added after reset", imap_add_mesh(ctx, &mesh, &id), IMAP_OK, ctx);

    imap_destroy(ctx);

    /* Photometry, on a fresh context: malformed files get IMAP_ERR_PARSE naming the line;
     * nothing is added. */
    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 2;
    expect("photometry context", imap_create(&cfg, &ctx), IMAP_OK, NULL);
    expect("grey", imap_add_material(ctx, &mat, &m_grey), IMAP_OK, ctx);
    mesh = square_mesh(m_grey);
    expect("floor", imap_add_mesh(ctx, &mesh, &floor_id), IMAP_OK, ctx);
    const char *ies = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n1000 700 0\n";
    ImapLuminaire place;
    imap_luminaire_default(&place, sizeof place);
    place.position[0] = 0.5, place.position[1] = 0.5, place.position[2] = 2;
    expect("IES file cut short", imap_add_luminaire_ies(ctx, ies, strlen(ies) - 4, NULL, 0, &place, NULL, &id),
           IMAP_ERR_PARSE, ctx);
    if (!strstr(imap_last_error(ctx), "IES line 7")) printf("FAIL the message names no line\n"), failures++;
    char bad[256];
    snprintf(bad, sizeof bad, "%s", ies);
    bad[strlen("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n0 4")] = 'x';
    expect("IES angle 'x5'", imap_add_luminaire_ies(ctx, bad, strlen(bad), NULL, 0, &place, NULL, &id), IMAP_ERR_PARSE, ctx);
    snprintf(bad, sizeof bad, "IESNA:LM-63-2002\nTILT=lamp.tlt\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n1 1 1\n");
    expect("TILT file not given", imap_add_luminaire_ies(ctx, bad, strlen(bad), NULL, 0, &place, NULL, &id), IMAP_ERR_PARSE,
           ctx);
    snprintf(bad, sizeof bad, "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 3 2 0 0 0\n1 1 10\n0 45 90\n0\n1 1 1\n");
    expect("photometric type A", imap_add_luminaire_ies(ctx, bad, strlen(bad), NULL, 0, &place, NULL, &id),
           IMAP_ERR_UNSUPPORTED, ctx);
    expect("empty IES text", imap_add_luminaire_ies(ctx, ies, 0, NULL, 0, &place, NULL, &id), IMAP_ERR_PARSE, ctx);
    expect("EULUMDAT garbage", imap_add_luminaire_ldt(ctx, "x\ny\n", 4, &place, NULL, &id), IMAP_ERR_PARSE, ctx);
    place.reference[0] = 0, place.reference[2] = -3;
    expect("reference parallel to aim", imap_add_luminaire_ies(ctx, ies, strlen(ies), NULL, 0, &place, NULL, &id),
           IMAP_ERR_INVALID_ARGUMENT, ctx);
    imap_luminaire_default(&place, sizeof place);
    place.position[0] = 0.5, place.position[1] = 0.5, place.position[2] = 2;
    ImapLight light;
    imap_light_default(&light, sizeof light);
    light.position[0] = 0.5, light.position[1] = 0.5, light.position[2] = 2;
    light.unit = 99, light.amount = 100;
    expect("light unit 99", imap_add_light(ctx, &light, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    light.unit = IMAP_UNIT_LX;
    expect("lux for a point light", imap_add_light(ctx, &light, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    light.unit = IMAP_UNIT_LM, light.amount = NAN;
    expect("amount NaN", imap_add_light(ctx, &light, NULL, &id), IMAP_ERR_NON_FINITE, ctx);
    ImapSpectrum spec;
    imap_spectrum_default(&spec, sizeof spec);
    spec.kind = 42;
    light.amount = 100;
    expect("spectrum kind 42", imap_add_light(ctx, &light, &spec, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    ImapLight zero_light;
    memset(&zero_light, 0, sizeof zero_light);
    expect("zeroed ImapLight", imap_add_light(ctx, &zero_light, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    /* Skies and the sun (Since 0.2.2): each bad field is named; the context keeps going. */
    ImapSky sky;
    imap_sky_default(&sky, sizeof sky);
    expect("sky amount 0", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sky.amount = 1000, sky.unit = 9;
    expect("sky unit 9", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sky.unit = IMAP_SKY_UNIT_SCALE;
    expect("scale for a uniform sky", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sky.unit = IMAP_SKY_UNIT_LUMINANCE, sky.kind = IMAP_SKY_CIE, sky.cie_type = 16;
    expect("CIE sky type 16", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sky.cie_type = 12;
    expect("CIE sky type 12 without its sun", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    if (!strstr(imap_last_error(ctx), "type 12 needs its sun")) printf("FAIL: %s\n", imap_last_error(ctx)), failures++;
    sky.sun_azimuth_deg = 180, sky.sun_zenith_deg = 95;
    expect("CIE sun below the horizon", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sky.sun_zenith_deg = 30, sky.north[0] = 0, sky.north[1] = 0, sky.north[2] = 5;
    expect("north along the zenith", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sky.north[1] = 1, sky.north[2] = 0, sky.kind = IMAP_SKY_IMAGE, sky.image_width = 4, sky.image_height = 2;
    expect("image sky without pixels", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_NULL_POINTER, ctx);
    sky.image_width = 65536, sky.image_height = 65536;
    expect("a 4-gigapixel image sky (refused before it is read)", imap_add_sky(ctx, &sky, NULL, &id),
           IMAP_ERR_MEMORY_BUDGET, ctx);
    sky.image_width = 4, sky.image_height = 2;
    float pixels[24] = {0};
    pixels[5] = NAN;
    sky.image_rgb = pixels, sky.unit = IMAP_SKY_UNIT_SCALE, sky.amount = 1;
    expect("image sky with a NaN pixel", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_NON_FINITE, ctx);
    pixels[5] = 0;
    expect("black image sky", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_NO_LIGHT, ctx);
    expect("sky file that does not exist", imap_add_sky_file(ctx, "/nonexistent/sky.hdr", &sky, &id), IMAP_ERR_IO, ctx);
    expect("sky file NULL", imap_add_sky_file(ctx, NULL, &sky, &id), IMAP_ERR_NULL_POINTER, ctx);
    ImapSun sun;
    imap_sun_default(&sun, sizeof sun);
    sun.amount = 80000, sun.unit = IMAP_UNIT_CD;
    expect("sun in candela", imap_add_sun(ctx, &sun, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sun.unit = IMAP_UNIT_LX, sun.zenith_deg = NAN;
    expect("sun zenith NaN", imap_add_sun(ctx, &sun, NULL, &id), IMAP_ERR_NON_FINITE, ctx);
    ImapSunTime when;
    imap_sun_time_default(&when, sizeof when);
    double az, zen;
    when.month = 13;
    expect("sun position in month 13", imap_sun_position(&when, &az, &zen), IMAP_ERR_INVALID_ARGUMENT, NULL);
    when.month = 6;
    expect("sun position without outputs", imap_sun_position(&when, NULL, &zen), IMAP_ERR_NULL_POINTER, NULL);
    expect("sun position", imap_sun_position(&when, &az, &zen), IMAP_OK, NULL);
    if (!(zen > 23 && zen < 24)) {
        printf("FAIL: the sun at noon UTC on 21 June at 0 N 0 E stands %.3f deg from the zenith (the tropic: ~23.4)\n", zen);
        failures++;
    }
    /* An hour's Perez sky (Since 0.2.3): bad weather is named; no diffuse light, no sky. */
    ImapPerezSky perez;
    expect("Perez sky of negative diffuse light", imap_perez_sky(600, -1, 30, 172, 2, &perez, sizeof perez),
           IMAP_ERR_INVALID_ARGUMENT, NULL);
    expect("Perez sky of NaN direct light", imap_perez_sky(NAN, 150, 30, 172, 2, &perez, sizeof perez),
           IMAP_ERR_NON_FINITE, NULL);
    expect("Perez sky on day 0", imap_perez_sky(600, 150, 30, 0, 2, &perez, sizeof perez), IMAP_ERR_INVALID_ARGUMENT,
           NULL);
    expect("Perez sky without diffuse light", imap_perez_sky(600, 0, 30, 172, 2, &perez, sizeof perez),
           IMAP_ERR_NO_LIGHT, NULL);
    expect("Perez sky into 4 bytes", imap_perez_sky(600, 150, 30, 172, 2, &perez, 4), IMAP_ERR_INVALID_ARGUMENT, NULL);
    expect("Perez sky into NULL", imap_perez_sky(600, 150, 30, 172, 2, NULL, sizeof perez), IMAP_ERR_NULL_POINTER,
           NULL);
    expect("Perez sky", imap_perez_sky(600, 150, 30, 172, 2, &perez, sizeof perez), IMAP_OK, NULL);
    /* ε = (750/150 + 1.041 Z³) / (1 + 1.041 Z³) = 4.48 at Z = 30°: bin 5 (2.8–4.5). */
    if (!(perez.bin == 5 && fabs(perez.clearness - 4.481) < 0.01 && perez.diffuse_horizontal_lx > 15000 &&
          perez.direct_normal_lx > 50000)) {
        printf("FAIL: Perez sky bin %u, clearness %.4f, %.0f lx diffuse, %.0f lx direct\n", perez.bin, perez.clearness,
               perez.diffuse_horizontal_lx, perez.direct_normal_lx);
        failures++;
    }
    sky.kind = IMAP_SKY_PEREZ, sky.unit = IMAP_SKY_UNIT_HORIZONTAL_LX, sky.amount = perez.diffuse_horizontal_lx;
    sky.sun_azimuth_deg = NAN, sky.perez_clearness = perez.clearness, sky.perez_brightness = perez.brightness;
    expect("Perez sky without its sun", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    sky.sun_azimuth_deg = 180, sky.sun_zenith_deg = 30, sky.perez_clearness = 0.5;
    expect("Perez sky of clearness 0.5", imap_add_sky(ctx, &sky, NULL, &id), IMAP_ERR_INVALID_ARGUMENT, ctx);
    if (!strstr(imap_last_error(ctx), "clearness")) printf("FAIL: %s\n", imap_last_error(ctx)), failures++;
    /* The context still works: a luminaire of 1000 cd cos-like, lux under it. */
    uint32_t lum;
    spec.kind = IMAP_SPECTRUM_BLACKBODY, spec.cct_k = 3000;
    expect("luminaire from IES text", imap_add_luminaire_ies(ctx, ies, strlen(ies), NULL, 0, &place, &spec, &lum), IMAP_OK,
           ctx);
    /* Its light in group 1, with the direct layer. */
    expect("layers: groups and direct", imap_set_layers(ctx, IMAP_KEEP_LIGHT_GROUPS | IMAP_KEEP_DIRECT), IMAP_OK, ctx);
    expect("group of light 7", imap_set_light_group(ctx, 7, 1), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    expect("group IMAP_MAX_LIGHT_GROUPS", imap_set_light_group(ctx, lum, IMAP_MAX_LIGHT_GROUPS), IMAP_ERR_INVALID_ARGUMENT,
           ctx);
    expect("light group of a mesh that does not emit", imap_set_mesh_light_group(ctx, floor_id, 1),
           IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("light group 1", imap_set_light_group(ctx, lum, 1), IMAP_OK, ctx);
    uint32_t groups = 0, direct = 0;
    expect("imap_get_layers", imap_get_layers(ctx, &groups, &direct), IMAP_OK, ctx);
    if (groups != 2 || direct != 1) printf("FAIL %u group layers, direct %u; want 2 and 1\n", groups, direct), failures++;
    double lm = 0;
    expect("imap_get_light_flux", imap_get_light_flux(ctx, lum, NULL, 0, &lm), IMAP_OK, ctx);
    if (!(lm > 1000 && lm < 4000)) printf("FAIL luminaire flux %g lm\n", lm), failures++;
    run.photons = 20000;
    expect("run with a luminaire", imap_run(ctx, &run, NULL, 0), IMAP_OK, ctx);
    double lux[4], xyz[12];
    expect("lux into 3 of 4", imap_get_vertex_illuminance(ctx, floor_id, 0, lux, 3), IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    expect("XYZ into 4 of 12", imap_get_vertex_xyz(ctx, floor_id, 0, xyz, 4), IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    expect("lux", imap_get_vertex_illuminance(ctx, floor_id, 0, lux, 4), IMAP_OK, ctx);
    expect("XYZ", imap_get_vertex_xyz(ctx, floor_id, 0, xyz, 12), IMAP_OK, ctx);
    double cct = 0, duv = 1;
    expect("CCT of the floor's light", imap_xyz_to_cct(xyz, &cct, &duv), IMAP_OK, NULL);
    if (!(fabs(lux[0] - xyz[1]) < 1e-9 * lux[0] && lux[0] > 0 && fabs(cct - 3000) < 5 && fabs(duv) < 1e-3))
        printf("FAIL lux %g, Y %g, CCT %g K, Duv %g\n", lux[0], xyz[1], cct, duv), failures++;
    /* All light is group 1's, and direct (nothing sends it back to the floor). */
    double g0[4], g1[4], dl[4];
    expect("lux of group 0", imap_get_layer_illuminance(ctx, floor_id, 0, 0, g0, 4), IMAP_OK, ctx);
    expect("lux of group 1", imap_get_layer_illuminance(ctx, floor_id, 0, 1, g1, 4), IMAP_OK, ctx);
    expect("lux of the direct layer", imap_get_layer_illuminance(ctx, floor_id, 0, IMAP_LAYER_DIRECT, dl, 4), IMAP_OK, ctx);
    expect("group 2 of 2", imap_get_layer_illuminance(ctx, floor_id, 0, 2, g0, 4), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    for (int i = 0; i < 4; i++)
        if (g0[i] != 0 || fabs(g1[i] - lux[i]) > 1e-12 * lux[i] || fabs(dl[i] - lux[i]) > 1e-12 * lux[i])
            printf("FAIL vertex %d: layers %g + %g, direct %g, lux %g\n", i, g0[i], g1[i], dl[i], lux[i]), failures++;
    /* A layer's region figures: group 1's and the direct layer's are the floor's; group 0 has nothing. */
    ImapRegionStats whole, grp, g0s;
    expect("floor figures", imap_get_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, &whole, sizeof whole), IMAP_OK, ctx);
    expect("group 1 figures", imap_get_layer_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, 1, &grp, sizeof grp), IMAP_OK,
           ctx);
    expect("group 0 figures", imap_get_layer_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, 0, &g0s, sizeof g0s), IMAP_OK,
           ctx);
    expect("group 2 figures", imap_get_layer_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, 2, &g0s, sizeof g0s),
           IMAP_ERR_INDEX_OUT_OF_RANGE, ctx);
    expect("layer figures, NULL", imap_get_layer_region_stats(ctx, floor_id, 0, IMAP_ALL_PARTS, 1, NULL, sizeof g0s),
           IMAP_ERR_NULL_POINTER, ctx);
    if (!(whole.average_lx > 0 && fabs(grp.average_lx - whole.average_lx) <= 1e-12 * whole.average_lx &&
          fabs(grp.average_lx_sigma - whole.average_lx_sigma) <= 1e-9 * whole.average_lx_sigma && g0s.flux_lm == 0))
        printf("FAIL layer figures: group 1 %g +- %g lx, whole %g +- %g lx, group 0 %g lm\n", grp.average_lx,
               grp.average_lx_sigma, whole.average_lx, whole.average_lx_sigma, g0s.flux_lm),
            failures++;
    double black[3] = {0, 0, 0};
    expect("CCT of black", imap_xyz_to_cct(black, &cct, NULL), IMAP_ERR_INVALID_ARGUMENT, NULL);
    expect("balance kind 9", imap_get_band_balance(ctx, 9, lux, 4), IMAP_ERR_INVALID_ARGUMENT, ctx);
    expect("balance kind 5", imap_get_band_balance(ctx, 5, lux, 4), IMAP_ERR_INVALID_ARGUMENT, ctx);
    double fluoresced[3] = {1, 1, 1};
    expect("balance fluoresced", imap_get_band_balance(ctx, IMAP_BALANCE_FLUORESCED, fluoresced, 3), IMAP_OK, ctx);
    if (fluoresced[0] != 0 || fluoresced[1] != 0 || fluoresced[2] != 0)
        printf("FAIL fluoresced without fluorescent surfaces: %g %g %g\n", fluoresced[0], fluoresced[1], fluoresced[2]),
            failures++;

    /* States: sizes, bad buffers, damaged states and files; the map survives each. */
    size_t size = 0;
    expect("state size", imap_state_write(ctx, 0, "m", 1, NULL, 0, &size), IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    expect("state: size NULL", imap_state_write(ctx, 0, NULL, 0, NULL, 0, NULL), IMAP_ERR_NULL_POINTER, ctx);
    expect("state: meta NULL", imap_state_write(ctx, 0, NULL, 4, NULL, 0, &size), IMAP_ERR_NULL_POINTER, ctx);
    expect("state: flag 8", imap_state_write(ctx, 8, NULL, 0, NULL, 0, &size), IMAP_ERR_INVALID_ARGUMENT, ctx);
    size_t need = 0;
    imap_state_write(ctx, 0, "m", 1, NULL, 0, &need);
    unsigned char *st = malloc(need);
    expect("state: one byte short", imap_state_write(ctx, 0, "m", 1, st, need - 1, &size), IMAP_ERR_BUFFER_TOO_SMALL, ctx);
    expect("state", imap_state_write(ctx, 0, "m", 1, st, need, &size), IMAP_OK, ctx);
    uint64_t held = 0;
    const void *meta = NULL;
    size_t meta_len = 0;
    expect("state info", imap_state_info(st, size, &held, &meta, &meta_len), IMAP_OK, NULL);
    ImapReport now;
    expect("report", imap_get_report(ctx, &now, sizeof now), IMAP_OK, ctx);
    if (held != now.photons || held == 0 || meta_len != 1 || *(const char *)meta != 'm')
        printf("FAIL state info: %llu photons, %zu bytes of metadata\n", (unsigned long long)held, meta_len), failures++;
    expect("merge a state into its own context", imap_state_merge(ctx, st, size), IMAP_ERR_STATE_OVERLAP, ctx);
    st[size / 2] ^= 4;
    expect("load a corrupted state", imap_state_load(ctx, st, size), IMAP_ERR_STATE_CORRUPT, ctx);
    st[size / 2] ^= 4;
    expect("load a truncated state", imap_state_load(ctx, st, size - 9), IMAP_ERR_STATE_CORRUPT, ctx);
    expect("load NULL", imap_state_load(ctx, NULL, 10), IMAP_ERR_NULL_POINTER, ctx);
    expect("info of nothing", imap_state_info(st, 3, NULL, NULL, NULL), IMAP_ERR_STATE_CORRUPT, NULL);
    expect("load from a missing file", imap_state_load_file(ctx, "/nonexistent/x.imap"), IMAP_ERR_IO, ctx);
    expect("merge from a NULL path", imap_state_merge_file(ctx, NULL), IMAP_ERR_NULL_POINTER, ctx);
    expect("save into a missing folder", imap_state_save(ctx, "/nonexistent/d/x.imap", NULL, 0), IMAP_ERR_IO, ctx);
    expect("save to an empty path", imap_state_save(ctx, "", NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    double lux2[4];
    expect("lux after the refused states", imap_get_vertex_illuminance(ctx, floor_id, 0, lux2, 4), IMAP_OK, ctx);
    if (memcmp(lux, lux2, sizeof lux) != 0) printf("FAIL the map changed under refused states\n"), failures++;
    /* The state loads into a fresh context of the same scene only. */
    expect("load into this context", imap_state_load(ctx, st, size), IMAP_OK, ctx);
    expect("run with a bad shard", (run.shard_count = 2, run.shard_index = 2, imap_run(ctx, &run, NULL, 0)),
           IMAP_ERR_INVALID_ARGUMENT, ctx);
    run.shard_count = 1, run.shard_index = 0, run.shard_block = 100;
    expect("run with a block of 100", imap_run(ctx, &run, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    run.shard_block = 0;
    double *acc = NULL;
    uint64_t acc_n = 0;
    expect("accumulators", imap_map_accumulators(ctx, &acc, &acc_n), IMAP_OK, ctx);
    expect("accumulators: count NULL", imap_map_accumulators(ctx, &acc, NULL), IMAP_ERR_NULL_POINTER, ctx);
    if (acc == NULL || acc_n == 0) printf("FAIL no accumulators\n"), failures++;
    expect("direct accumulators", imap_map_direct_accumulators(ctx, &acc, &acc_n), IMAP_OK, ctx);
    expect("direct accumulators: data NULL", imap_map_direct_accumulators(ctx, NULL, &acc_n),
           IMAP_ERR_NULL_POINTER, ctx);
    if (acc == NULL || acc_n == 0) printf("FAIL no direct accumulators (light sampling)\n"), failures++;
    /* Estimators: an unknown one, tuning for photons only, too few photons per pass, and
       another estimator than the map's photons (out of order); nothing changes. */
    run.estimator = 4;
    expect("run with estimator 4", imap_run(ctx, &run, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    run.estimator = 7;
    expect("run with estimator 7", imap_run(ctx, &run, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    run.estimator = IMAP_ESTIMATOR_PHOTONS, run.direct_samples = 8;
    expect("photons with direct samples", imap_run(ctx, &run, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    run.estimator = IMAP_ESTIMATOR_LIGHT_SAMPLING, run.direct_samples = 0, run.direct_pass_photons = 4096;
    expect("other photons per pass than the map's", imap_run(ctx, &run, NULL, 0), IMAP_ERR_OUT_OF_ORDER, ctx);
    run.direct_pass_photons = 0, run.direct_samples = 100000;
    expect("100000 direct samples", imap_run(ctx, &run, NULL, 0), IMAP_ERR_INVALID_ARGUMENT, ctx);
    run.direct_samples = 0, run.estimator = IMAP_ESTIMATOR_PHOTONS;
    expect("another estimator than the map's", imap_run(ctx, &run, NULL, 0), IMAP_ERR_OUT_OF_ORDER, ctx);
    run.estimator = IMAP_ESTIMATOR_GATHER;
    expect("gathering on a light-sampling map", imap_run(ctx, &run, NULL, 0), IMAP_ERR_OUT_OF_ORDER, ctx);
    run.estimator = IMAP_ESTIMATOR_DEFAULT;
    free(st);
    imap_destroy(ctx);
    imap_destroy(NULL);
    printf("%d failure%s\n", failures, failures == 1 ? "" : "s");
    return failures ? 1 : 0;
}
