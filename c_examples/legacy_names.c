/*
 * imap.h beside a legacy program's names: every name the header declares carries the
 * imap prefix, so none of these collides with it (before, the header defined BATCH,
 * EMITTER_FLOOR, NO_DATA_REL_ERROR and RGB_WAVELENGTHS_NM, and this did not compile).
 * Compiled with -Wall -Wextra -Wpedantic -Werror.
 */
enum { BATCH = 1, EMITTER_FLOOR = 2, NO_DATA_REL_ERROR = 3, MAX_HISTORY = 4, OK = 5, BUSY = 6 };
typedef int SceneKind;
typedef double Config;
#define RGB_WAVELENGTHS_NM 7
#define MAX_THREADS 8
struct Report {
    int x;
};
static int Progress(int x) { return x + 1; }

#include <imap.h>

#include <stdio.h>

int main(void) {
    SceneKind kind = BATCH + EMITTER_FLOOR + NO_DATA_REL_ERROR + MAX_HISTORY + OK + BUSY;
    Config c = RGB_WAVELENGTHS_NM + MAX_THREADS;
    struct Report r = {Progress(kind)};
    ImapConfig cfg;
    ImapStatus s = imap_config_default(&cfg, sizeof cfg);
    printf("libimap %s beside legacy names: %s (%d %.0f %d)\n", imap_version(), imap_status_name(s), kind, c, r.x);
    return s == IMAP_OK ? 0 : 1;
}
