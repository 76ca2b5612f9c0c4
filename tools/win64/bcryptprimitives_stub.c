/* ProcessPrng for wine 8, which lacks bcryptprimitives.dll: Rust's standard library (1.78 and
 * later) draws its random seeds from it on Windows 10 and later, where the system provides it.
 * Only the test under wine uses this stub, never a shipped FMU: it fills the buffer through
 * advapi32's RtlGenRandom (SystemFunction036), which wine has. */
#include <windows.h>

BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length) {
    while (length > 0) {
        ULONG chunk = length > 0x10000000 ? 0x10000000 : (ULONG)length;
        if (!SystemFunction036(data, chunk)) return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
