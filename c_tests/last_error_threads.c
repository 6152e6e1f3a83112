/*
 * Error messages under concurrency, built with AddressSanitizer: one thread runs while two
 * others keep calling the same context, get IMAP_ERR_BUSY, and read their message through
 * imap_last_error(ctx) while the other poller fails again. Each message belongs to the
 * thread that failed, so no thread can free the string another is reading: before, this
 * was a heap-use-after-free. Also checks that the running thread's own earlier message
 * survives the others' BUSY answers.
 */
#include <imap.h>

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

static ImapContext *ctx;
static atomic_int done;
static uint32_t mesh;

static void *poll_context(void *arg) {
    intptr_t busy = 0;
    double out[64];
    char copy[512];
    (void)arg;
    while (!atomic_load(&done)) {
        if (imap_get_vertex_energy(ctx, mesh, IMAP_SIDE_FRONT, 0, out, 64) != IMAP_ERR_BUSY) continue;
        busy++;
        const char *msg = imap_last_error(ctx);
        /* Read the string slowly, twice, while the other poller fails over and over. */
        size_t n = strlen(msg);
        if (n == 0 || n >= sizeof copy) return (void *)(intptr_t)-1;
        memcpy(copy, msg, n + 1);
        for (int spin = 0; spin < 100; spin++) atomic_thread_fence(memory_order_seq_cst);
        if (strcmp(copy, msg) != 0 || strstr(msg, "in use by another call") == NULL) return (void *)(intptr_t)-1;
    }
    return (void *)busy;
}

int main(void) {
    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    cfg.threads = 2;
    if (imap_create(&cfg, &ctx) != IMAP_OK) return 1;
    double xyz[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, grey = 0.5, pos[3] = {0.5, 0.5, 1}, watts = 1;
    uint32_t idx[6] = {0, 1, 2, 0, 2, 3}, mat, light;
    ImapMaterial m;
    imap_material_default(&m, sizeof m);
    m.diffuse_reflectance = &grey, m.diffuse_reflectance_count = 1;
    ImapMesh d;
    imap_mesh_default(&d, sizeof d);
    d.positions = xyz, d.vertex_count = 4, d.indices = idx, d.triangle_count = 2, d.flags = IMAP_MESH_RECORD;
    if (imap_add_material(ctx, &m, &mat) || (d.material = mat, imap_add_mesh(ctx, &d, &mesh)) ||
        imap_add_point_light(ctx, pos, &watts, 1, &light))
        return 1;
    /* The running thread's own failure first. */
    double out[4];
    if (imap_get_vertex_energy(ctx, mesh, IMAP_SIDE_FRONT, 99, out, 4) != IMAP_ERR_INDEX_OUT_OF_RANGE) return 1;
    char mine[512];
    snprintf(mine, sizeof mine, "%s", imap_last_error(ctx));

    pthread_t t[2];
    for (int i = 0; i < 2; i++) pthread_create(&t[i], NULL, poll_context, NULL);
    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.time_budget_s = 1.5;
    ImapStatus s;
    while ((s = imap_run(ctx, &run, NULL, 0)) == IMAP_ERR_BUSY) {
    }
    atomic_store(&done, 1);
    intptr_t busy[2];
    for (int i = 0; i < 2; i++) {
        void *r;
        pthread_join(t[i], &r);
        busy[i] = (intptr_t)r;
    }
    printf("run: %s; BUSY answers read by the pollers: %ld and %ld\n", imap_status_name(s), (long)busy[0], (long)busy[1]);
    if (s != IMAP_OK || busy[0] <= 0 || busy[1] <= 0) return 1;
    /* This thread's last failure is still its own (or its own BUSY, had its run been the
     * one refused above). */
    const char *now = imap_last_error(ctx);
    printf("the running thread's message: \"%s\"\n", now);
    if (strcmp(now, mine) != 0 && strstr(now, "in use by another call") == NULL) return 1;
    imap_destroy(ctx);
    return 0;
}
