/* imap.h as a C89 compiler sees it (-std=c89 -pedantic -Werror): a legacy package built
 * as ANSI C includes the header and makes a context. Only <stdint.h> and <stddef.h> are
 * needed beyond C89 (the fixed-width types of the ABI). */
#include <imap.h>

#include <stdio.h>

int main(void) {
    ImapConfig cfg;
    ImapContext *ctx = NULL;
    ImapStatus s;
    s = imap_config_default(&cfg, sizeof cfg);
    if (s != IMAP_OK) return 1;
    cfg.threads = 1;
    s = imap_create(&cfg, &ctx);
    if (s != IMAP_OK) {
        printf("FAIL %s\n", imap_last_error(NULL));
        return 1;
    }
    printf("libimap %d.%d.%d from a C89 program: %s\n", IMAP_VERSION_MAJOR, IMAP_VERSION_MINOR, IMAP_VERSION_PATCH,
           imap_status_name(s));
    return imap_destroy(ctx) == IMAP_OK ? 0 : 1;
}
