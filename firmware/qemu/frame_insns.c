/*
 * A QEMU TCG plugin that counts the guest instructions executed between two addresses, once
 * per pass: the firmware calls `frame_start` before and `frame_end` after every `Rig::deform`,
 * and this prints `frame_insns <n>` for each frame on QEMU's log (stderr), then
 * `frame_cycles <n>`: an estimate of the Cortex-M4 cycles those instructions take (QEMU does not
 * model time), each executed instruction timed by its class in the Cortex-M4 Technical Reference
 * Manual (ARM DDI 0439, section 3.3 "Instruction set summary"):
 *
 *   - LDR/LDRB/LDRH/LDRSB/LDRSH 2 cycles, 1 when the instruction before it in the block is such a
 *     single load whose destination it does not address with (pipelined loads);
 *   - STR/STRB/STRH 1; LDRD/STRD 3; LDM/STM/PUSH/POP 1 + the number of registers (+2 when POP
 *     loads the PC: a pipeline refill);
 *   - MLA/MLS 2; SDIV/UDIV 12 (the TRM gives 2 to 12: the worst); every other data operation,
 *     MUL, the 32x32->64 multiplies and the DSP multiplies (SMLAD, SMUAD, SMLAL...) 1;
 *   - a load or store addressed by the result of the data operation just before it: +1 (the
 *     address generation has no forwarding path from it);
 *   - B, BL, BX, BLX: 1 + 2 (the pipeline refill; the TRM gives 1 to 3); a conditional branch
 *     or CBZ/CBNZ 1, and 1 + 2 when taken (seen from the next block executed);
 *   - IT 1 (the TRM lets it fold into the instruction before: an upper bound).
 *
 * Memory is taken as zero-wait-state (on-chip flash with an accelerator, or SRAM) and every
 * access aligned.
 *
 *   qemu-system-arm ... -plugin ./frame_insns.so,start=0x<addr>,end=0x<addr> -d plugin
 *
 * Instructions are counted per translation block as it is entered (an inline add of the block's
 * length), which is exact for code that takes no exception, as a frame does not. The count
 * includes the two marker functions' blocks, a constant few instructions per frame.
 *
 * Debian ships QEMU with plugin support but no plugin headers, so the handful of API
 * declarations this needs (plugin API version 1, QEMU 7.x) are written out here.
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;

enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };

typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);

void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                              void *ptr, uint64_t imm);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn,
                                            qemu_plugin_vcpu_udata_cb_t cb,
                                            enum qemu_plugin_cb_flags flags, void *userdata);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_outs(const char *string);

#define EXPORT __attribute__((visibility("default")))

EXPORT int qemu_plugin_version = 1;

char *qemu_plugin_insn_disas(const struct qemu_plugin_insn *insn);
size_t qemu_plugin_insn_size(const struct qemu_plugin_insn *insn);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *tb, qemu_plugin_vcpu_udata_cb_t cb,
                                          enum qemu_plugin_cb_flags flags, void *userdata);

static uint64_t executed;   /* instructions executed so far (single vCPU) */
static uint64_t at_start;   /* `executed` when the current frame started */
static uint64_t start_addr; /* first instruction of frame_start */
static uint64_t end_addr;   /* first instruction of frame_end */
static uint64_t cycles;     /* estimated cycles so far (see the top) */
static uint64_t cycles_at_start;
static uint64_t branch_fallthrough; /* the block just run ended in a conditional branch: its
                                       fall-through address, else 0 */

/* What the exec callback needs of a translated block: its cycles without the taken-branch
 * refill, and the fall-through address when it ends in a conditional branch. */
struct block {
    uint64_t pc;
    uint64_t cycles;
    uint64_t fallthrough;
};

static void on_start(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    (void)udata;
    at_start = executed;
    cycles_at_start = cycles;
}

static void on_end(unsigned int vcpu, void *udata)
{
    char line[64];
    (void)vcpu;
    (void)udata;
    snprintf(line, sizeof line, "frame_insns %" PRIu64 "\n", executed - at_start);
    qemu_plugin_outs(line);
    snprintf(line, sizeof line, "frame_cycles %" PRIu64 "\n", cycles - cycles_at_start);
    qemu_plugin_outs(line);
}


/* The mnemonic of a disassembled instruction, without a .w/.n width suffix. */
static void mnemonic_of(const char *disas, char *out, size_t size)
{
    size_t n = 0;
    while (disas[n] && disas[n] != ' ' && disas[n] != '.' && n + 1 < size) {
        out[n] = disas[n];
        n++;
    }
    out[n] = 0;
}

static int starts(const char *s, const char *prefix) { return strncmp(s, prefix, strlen(prefix)) == 0; }

static int is_condition(const char *c)
{
    static const char *codes[] = {"eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs",
                                  "vc", "hi", "ls", "ge", "lt", "gt", "le"};
    for (size_t i = 0; i < sizeof codes / sizeof *codes; i++) {
        if (strcmp(c, codes[i]) == 0) {
            return 1;
        }
    }
    return 0;
}

/* A single load: LDR, LDRB, LDRH, LDRSB, LDRSH, possibly conditional (in an IT block). */
static int single_load(const char *m)
{
    static const char *forms[] = {"ldrsb", "ldrsh", "ldrb", "ldrh", "ldr"};
    for (size_t i = 0; i < sizeof forms / sizeof *forms; i++) {
        size_t n = strlen(forms[i]);
        if (strncmp(m, forms[i], n) == 0 && (m[n] == 0 || is_condition(m + n))) {
            return 1;
        }
    }
    return 0;
}

/* The first operand (the destination of a data operation or load), e.g. "r3". */
static void destination_of(const char *disas, char *out, size_t size)
{
    const char *p = strchr(disas, ' ');
    size_t n = 0;
    while (p && *p == ' ') {
        p++;
    }
    while (p && p[n] && p[n] != ',' && p[n] != ' ' && n + 1 < size) {
        out[n] = p[n];
        n++;
    }
    out[n] = 0;
}

/* Whether the bracketed address of a memory operand names register `reg`. */
static int addresses_with(const char *disas, const char *reg)
{
    const char *open = strchr(disas, '['), *close = open ? strchr(open, ']') : NULL;
    size_t n = strlen(reg);
    if (!open || !close || n == 0) {
        return 0;
    }
    for (const char *p = open + 1; p + n <= close; p++) {
        int before = p == open + 1 || p[-1] == ' ' || p[-1] == ',';
        int after = p[n] == ',' || p[n] == ']' || p[n] == ' ';
        if (before && after && strncmp(p, reg, n) == 0) {
            return 1;
        }
    }
    return 0;
}

/* Registers in a {...} list. */
static int register_count(const char *disas)
{
    const char *open = strchr(disas, '{');
    int n = 1;
    if (!open) {
        return 1;
    }
    for (const char *p = open; *p && *p != '}'; p++) {
        n += *p == ',';
    }
    return n;
}

enum kind { DATA, LOAD, STORE, OTHER_MEMORY, BRANCH };

/* The cycles of one instruction (see the top), given the one before it in the block. */
static uint64_t instruction_cycles(const char *disas, const char *before, enum kind *kind, int *cond_branch)
{
    char m[32], p[32] = "", dst[16] = "";
    mnemonic_of(disas, m, sizeof m);
    if (before) {
        mnemonic_of(before, p, sizeof p);
        destination_of(before, dst, sizeof dst);
    }
    *cond_branch = 0;
    uint64_t c;
    if (strcmp(m, "b") == 0 || strcmp(m, "bl") == 0 || strcmp(m, "bx") == 0 || strcmp(m, "blx") == 0) {
        *kind = BRANCH;
        return 3;
    }
    if ((m[0] == 'b' && is_condition(m + 1)) || strcmp(m, "cbz") == 0 || strcmp(m, "cbnz") == 0) {
        *kind = BRANCH;
        *cond_branch = 1;
        return 1;
    }
    if (single_load(m)) {
        *kind = LOAD;
        c = (before && single_load(p) && !addresses_with(disas, dst)) ? 1 : 2;
    } else if (starts(m, "ldrd") || starts(m, "strd")) {
        *kind = OTHER_MEMORY;
        c = 3;
    } else if (starts(m, "str")) {
        *kind = STORE;
        c = 1;
    } else if (starts(m, "ldm") || starts(m, "stm") || starts(m, "push") || starts(m, "pop")) {
        *kind = OTHER_MEMORY;
        c = 1 + register_count(disas);
        if (starts(m, "pop") && strstr(disas, "pc")) {
            c += 2;
        }
    } else if (starts(m, "mla") || starts(m, "mls")) {
        *kind = DATA;
        c = 2;
    } else if (starts(m, "sdiv") || starts(m, "udiv")) {
        *kind = DATA;
        c = 12;
    } else {
        *kind = DATA;
        c = 1;
    }
    /* A memory access addressed by the result of the data operation just before it. */
    if (*kind != DATA && before && !single_load(p) && !starts(p, "str") && !starts(p, "ldm") &&
        !starts(p, "stm") && !starts(p, "push") && !starts(p, "pop") && !starts(p, "ldrd") &&
        !starts(p, "strd") && p[0] != 'b' && addresses_with(disas, dst)) {
        c++;
    }
    return c;
}

static void on_block(unsigned int vcpu, void *udata)
{
    const struct block *b = udata;
    (void)vcpu;
    /* The block before ended in a conditional branch, taken if this is not its fall-through. */
    if (branch_fallthrough != 0 && b->pc != branch_fallthrough) {
        cycles += 2;
    }
    cycles += b->cycles;
    branch_fallthrough = b->fallthrough;
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    size_t n = qemu_plugin_tb_n_insns(tb);
    (void)id;
    struct block *b = calloc(1, sizeof *b);
    char *before = NULL;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &executed, n);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        char *disas = qemu_plugin_insn_disas(insn);
        enum kind kind;
        int cond_branch;
        if (b && disas) {
            b->cycles += instruction_cycles(disas, before, &kind, &cond_branch);
            if (i == 0) {
                b->pc = pc;
            }
            if (i == n - 1 && cond_branch) {
                b->fallthrough = pc + qemu_plugin_insn_size(insn);
            }
        }
        free(before);
        before = disas;
        if (pc == start_addr) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_start, QEMU_PLUGIN_CB_NO_REGS, NULL);
        } else if (pc == end_addr) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
        }
    }
    free(before);
    if (b) {
        qemu_plugin_register_vcpu_tb_exec_cb(tb, on_block, QEMU_PLUGIN_CB_NO_REGS, b);
    }
}

EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        /* Thumb symbol addresses have bit 0 set; instruction addresses do not. */
        if (strncmp(argv[i], "start=", 6) == 0) {
            start_addr = strtoull(argv[i] + 6, NULL, 0) & ~1ull;
        } else if (strncmp(argv[i], "end=", 4) == 0) {
            end_addr = strtoull(argv[i] + 4, NULL, 0) & ~1ull;
        }
    }
    if (start_addr == 0 || end_addr == 0 || start_addr == end_addr) {
        fprintf(stderr, "frame_insns: need distinct start=0x.. and end=0x.. addresses\n");
        return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    return 0;
}
