/*
 * Windows only: imap.dll and imap.exe (beside it, in the package's bin/) carry version
 * resources whose file and product versions are the library's own (imap_version() and the
 * header's IMAP_VERSION_*), with the strings a host's installer or Explorer shows.
 */
#include <imap.h>

#include <stdio.h>
#include <string.h>
#include <wchar.h>
#include <windows.h>

static int failures = 0;

/* Checks one file's VERSIONINFO; NAME is for the messages. */
static void check_file(const wchar_t *path, const char *name, const wchar_t *original) {
    DWORD ignored = 0, size = GetFileVersionInfoSizeW(path, &ignored);
    static unsigned char data[1 << 16];
    if (size == 0 || size > sizeof data || !GetFileVersionInfoW(path, 0, size, data)) {
        printf("FAIL %s: no version resource (error %lu)\n", name, (unsigned long)GetLastError());
        failures++;
        return;
    }
    VS_FIXEDFILEINFO *fixed = NULL;
    UINT len = 0;
    if (!VerQueryValueW(data, L"\\", (void **)&fixed, &len) || len < sizeof *fixed ||
        fixed->dwSignature != 0xFEEF04BDu) {
        printf("FAIL %s: no fixed file information\n", name);
        failures++;
        return;
    }
    unsigned got[4] = {HIWORD(fixed->dwFileVersionMS), LOWORD(fixed->dwFileVersionMS),
                       HIWORD(fixed->dwFileVersionLS), LOWORD(fixed->dwFileVersionLS)};
    unsigned product[3] = {HIWORD(fixed->dwProductVersionMS), LOWORD(fixed->dwProductVersionMS),
                           HIWORD(fixed->dwProductVersionLS)};
    char text[64];
    snprintf(text, sizeof text, "%u.%u.%u", got[0], got[1], got[2]);
    if (got[0] != IMAP_VERSION_MAJOR || got[1] != IMAP_VERSION_MINOR || got[2] != IMAP_VERSION_PATCH ||
        got[3] != 0 || strcmp(text, imap_version()) != 0 || product[0] != got[0] ||
        product[1] != got[1] || product[2] != got[2]) {
        printf("FAIL %s: file version %u.%u.%u.%u, product %u.%u.%u; the library is %s\n", name, got[0],
               got[1], got[2], got[3], product[0], product[1], product[2], imap_version());
        failures++;
    }
    DWORD want_type = wcsstr(original, L".dll") ? VFT_DLL : VFT_APP;
    if (fixed->dwFileType != want_type) {
        printf("FAIL %s: file type %lu, want %lu\n", name, (unsigned long)fixed->dwFileType,
               (unsigned long)want_type);
        failures++;
    }
    const wchar_t *keys[3] = {L"\\StringFileInfo\\040904b0\\FileVersion",
                              L"\\StringFileInfo\\040904b0\\ProductName",
                              L"\\StringFileInfo\\040904b0\\OriginalFilename"};
    wchar_t want_version[64];
    swprintf(want_version, 64, L"%hs", imap_version());
    const wchar_t *want[3] = {want_version, L"libimap", original};
    for (int i = 0; i < 3; i++) {
        wchar_t *value = NULL;
        if (!VerQueryValueW(data, keys[i], (void **)&value, &len) || wcscmp(value, want[i]) != 0) {
            printf("FAIL %s: %ls is '%ls', want '%ls'\n", name, keys[i], value ? value : L"(none)", want[i]);
            failures++;
        }
    }
    printf("%s %s: version %s\n", failures ? "FAIL" : "ok  ", name, text);
}

int main(void) {
    /* The DLL this program loaded, and the command beside it. */
    wchar_t dll[MAX_PATH], exe[MAX_PATH];
    HMODULE module = GetModuleHandleW(L"imap.dll");
    DWORD n = module ? GetModuleFileNameW(module, dll, MAX_PATH) : 0;
    if (n == 0 || n >= MAX_PATH) {
        printf("FAIL imap.dll is not loaded\n");
        return 1;
    }
    check_file(dll, "imap.dll", L"imap.dll");
    wcscpy(exe, dll);
    wchar_t *slash = wcsrchr(exe, L'\\');
    wcscpy(slash ? slash + 1 : exe, L"imap.exe");
    if (GetFileAttributesW(exe) != INVALID_FILE_ATTRIBUTES) {
        check_file(exe, "imap.exe", L"imap.exe");
    } else {
        printf("FAIL no imap.exe beside %ls\n", dll);
        failures++;
    }
    printf("%s\n", failures ? "FAILED" : "all passed");
    return failures ? 1 : 0;
}
