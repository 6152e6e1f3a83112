/*
 * The Cornell box on several MPI ranks: rank r traces shard r of the photons 0 … N−1
 * (blocks of 65 536 photons dealt round robin), the ranks sum their map accumulators
 * with MPI_Reduce straight on the array the library exposes (MPI_IN_PLACE at rank 0), and
 * rank 0 merges the other ranks' small "ledgers" (their states without the map: photon
 * ranges, energy and region tallies, run times). Rank 0 then holds exactly the map of one
 * process tracing the N photons; it writes it as a state file when asked, and checks it
 * against one process tracing them (every vertex, band and error to 1e-12).
 *
 *   mpirun -np 2 mpi_cornell [photons = 2000000] [threads per rank = 1] [bands = 3]
 *                            [state file to write] [check = 1]
 */
#include <mpi.h>

#include "cornell_scene.h"

#include <limits.h>

#define CHECK(call)                                                                                                    \
    do {                                                                                                               \
        ImapStatus s_ = (call);                                                                                        \
        if (s_ != IMAP_OK) cornell_fail(ctx, #call, s_);                                                               \
    } while (0)

/* A context holding the recording Cornell box. */
static ImapContext *box_context(Cornell *box, int bands, int threads) {
    ImapConfig cfg;
    cornell_config(&cfg, bands);
    cfg.threads = (uint32_t)threads;
    ImapContext *ctx = NULL;
    CHECK(imap_create(&cfg, &ctx));
    cornell_build(ctx, box, bands, 1, 1, 24);
    return ctx;
}

/* Traces shard `shard` of `shards` of the photons [0, photons). */
static void run_shard(ImapContext *ctx, uint64_t photons, int shard, int shards) {
    ImapRunParams run;
    imap_run_params_default(&run, sizeof run);
    run.photon_first = 0;
    run.photon_count = photons;
    run.shard_count = (uint64_t)shards;
    run.shard_index = (uint64_t)shard;
    run.photons = 0; /* this shard's photons of the range, to their end */
    ImapReport rep;
    CHECK(imap_run(ctx, &run, &rep, sizeof rep));
}

/* Sums an array of every rank into rank 0's, in pieces an int can count. */
static void reduce_array(double *data, uint64_t count, int rank) {
    const uint64_t piece = 1u << 27;
    for (uint64_t at = 0; at < count; at += piece) {
        int n = (int)(count - at < piece ? count - at : piece);
        if (rank == 0)
            MPI_Reduce(MPI_IN_PLACE, data + at, n, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
        else
            MPI_Reduce(data + at, NULL, n, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
    }
}

/* Sums the map accumulators of every rank into rank 0's: the photons' and, with light
   sampling (the default estimator), the direct records. */
static void reduce_maps(ImapContext *ctx, int rank) {
    double *data = NULL;
    uint64_t count = 0;
    CHECK(imap_map_accumulators(ctx, &data, &count));
    reduce_array(data, count, rank);
    CHECK(imap_map_direct_accumulators(ctx, &data, &count));
    reduce_array(data, count, rank);
}

/* Gathers every rank's ledger (its state without the map) at rank 0, which merges them. */
static void merge_ledgers(ImapContext *ctx, int rank, int ranks) {
    size_t size = 0;
    ImapStatus s = imap_state_write(ctx, IMAP_STATE_NO_MAP, NULL, 0, NULL, 0, &size);
    if (s != IMAP_ERR_BUFFER_TOO_SMALL) cornell_fail(ctx, "imap_state_write (size)", s);
    char *mine = malloc(size);
    CHECK(imap_state_write(ctx, IMAP_STATE_NO_MAP, NULL, 0, mine, size, &size));
    if (size > INT_MAX) {
        fprintf(stderr, "a ledger of %zu bytes is too large for MPI_Gatherv\n", size);
        MPI_Abort(MPI_COMM_WORLD, 1);
    }
    int len = (int)size;
    int *lens = NULL, *offsets = NULL;
    char *all = NULL;
    if (rank == 0) {
        lens = malloc(sizeof(int) * (size_t)ranks);
        offsets = malloc(sizeof(int) * (size_t)ranks);
    }
    MPI_Gather(&len, 1, MPI_INT, lens, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (rank == 0) {
        long total = 0;
        for (int r = 0; r < ranks; r++) {
            offsets[r] = (int)total;
            total += lens[r];
        }
        all = malloc((size_t)total);
    }
    MPI_Gatherv(mine, len, MPI_CHAR, all, lens, offsets, MPI_CHAR, 0, MPI_COMM_WORLD);
    if (rank == 0) {
        for (int r = 1; r < ranks; r++) CHECK(imap_state_merge(ctx, all + offsets[r], (size_t)lens[r]));
        free(lens), free(offsets), free(all);
    }
    free(mine);
}

/* Largest relative difference between two contexts' maps (every recording mesh, band and
 * the error), and whether both hold something. */
static double compare(ImapContext *a, ImapContext *b, const Cornell *box, int bands) {
    double worst = 0, any = 0;
    for (int p = 0; p < CB_PARTS; p++) {
        if (p == CB_LAMP) continue;
        size_t nv = box->part[p].nv;
        double *x = malloc(nv * sizeof(double)), *y = malloc(nv * sizeof(double));
        for (int band = -1; band < bands; band++) {
            ImapContext *ctx = a;
            if (band < 0) {
                CHECK(imap_get_vertex_error(a, box->id[p], IMAP_SIDE_FRONT, x, nv));
                ctx = b;
                CHECK(imap_get_vertex_error(b, box->id[p], IMAP_SIDE_FRONT, y, nv));
            } else {
                CHECK(imap_get_vertex_energy(a, box->id[p], IMAP_SIDE_FRONT, (uint32_t)band, x, nv));
                ctx = b;
                CHECK(imap_get_vertex_energy(b, box->id[p], IMAP_SIDE_FRONT, (uint32_t)band, y, nv));
            }
            for (size_t v = 0; v < nv; v++) {
                double scale = fmax(fabs(x[v]), fabs(y[v]));
                if (scale > 0) worst = fmax(worst, fabs(x[v] - y[v]) / scale);
                any += x[v];
            }
        }
        free(x), free(y);
    }
    return any > 0 ? worst : INFINITY;
}

int main(int argc, char **argv) {
    MPI_Init(&argc, &argv);
    int rank = 0, ranks = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    uint64_t photons = argc > 1 ? strtoull(argv[1], NULL, 10) : 2000000;
    int threads = argc > 2 ? atoi(argv[2]) : 1;
    int bands = argc > 3 ? atoi(argv[3]) : 3;
    const char *state_path = argc > 4 && argv[4][0] ? argv[4] : NULL;
    int check = argc > 5 ? atoi(argv[5]) : 1;

    Cornell box;
    ImapContext *ctx = box_context(&box, bands, threads);

    MPI_Barrier(MPI_COMM_WORLD);
    double t0 = MPI_Wtime();
    run_shard(ctx, photons, rank, ranks);
    double t_run = MPI_Wtime() - t0;
    MPI_Barrier(MPI_COMM_WORLD);
    double t1 = MPI_Wtime();
    reduce_maps(ctx, rank);
    merge_ledgers(ctx, rank, ranks);
    double t_reduce = MPI_Wtime() - t1, t_all = MPI_Wtime() - t0;
    double slowest = 0;
    MPI_Reduce(&t_run, &slowest, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);

    int ok = 1;
    if (rank == 0) {
        ImapReport rep;
        CHECK(imap_get_report(ctx, &rep, sizeof rep));
        double *acc = NULL;
        uint64_t count = 0;
        CHECK(imap_map_accumulators(ctx, &acc, &count));
        printf("%d rank%s × %d thread%s, %d bands: %llu photons traced in %.3f s (slowest rank), reduce + merge "
               "%.3f s (%llu doubles), %.3f s in all; estimated error %.4f\n",
               ranks, ranks == 1 ? "" : "s", threads, threads == 1 ? "" : "s", bands,
               (unsigned long long)rep.photons, slowest, t_reduce, (unsigned long long)count, t_all, rep.rel_error);
        if (rep.photons != photons) {
            fprintf(stderr, "FAIL: rank 0 holds %llu photons, not %llu\n", (unsigned long long)rep.photons,
                    (unsigned long long)photons);
            ok = 0;
        }
        if (state_path) {
            CHECK(imap_state_save(ctx, state_path, "mpi_cornell", 11));
            printf("state written to %s\n", state_path);
        }
        if (check) {
            /* One process, the same photons (as many threads as all ranks had). */
            Cornell one_box;
            ImapContext *one = box_context(&one_box, bands, threads * ranks);
            double t2 = MPI_Wtime();
            run_shard(one, photons, 0, 1);
            double t_one = MPI_Wtime() - t2;
            double worst = compare(ctx, one, &box, bands);
            printf("one process, %d thread%s: %.3f s; largest relative difference of the maps and errors %.2e\n",
                   threads * ranks, threads * ranks == 1 ? "" : "s", t_one, worst);
            if (!(worst <= 1e-12)) {
                fprintf(stderr, "FAIL: the reduced map differs from one process's by %.3e\n", worst);
                ok = 0;
            }
            cornell_free(&one_box);
            imap_destroy(one);
        }
    }
    cornell_free(&box);
    imap_destroy(ctx);
    MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
    MPI_Finalize();
    return ok ? 0 : 1;
}
