/* Test support: NKeys, NATS JWTs and .creds files (see natscreds.h). */
#include "natscreds.h"

#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <openssl/evp.h>
#include <openssl/rand.h>

#define PREFIX_SEED (18 << 3) /* 'S' */

/* The first byte of a public key of type (its first base32 character is type). */
static int prefix_of(char type)
{
    switch (type) {
    case 'O': return 14 << 3;
    case 'A': return 0;
    case 'U': return 20 << 3;
    default: return -1;
    }
}

/* CRC-16/XMODEM (polynomial 0x1021, initial 0), NKeys' checksum. */
static uint16_t crc16(const unsigned char *p, size_t n)
{
    uint16_t crc = 0;
    for (size_t i = 0; i < n; i++) {
        crc ^= (uint16_t)(p[i] << 8);
        for (int b = 0; b < 8; b++) crc = (uint16_t)(crc & 0x8000 ? (crc << 1) ^ 0x1021 : crc << 1);
    }
    return crc;
}

/* RFC 4648 base32 without padding into out (NUL-terminated; cap >= n * 8 / 5 + 2). */
static void base32(char *out, const unsigned char *p, size_t n)
{
    static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZ234567";
    uint32_t acc = 0;
    int bits = 0;
    for (size_t i = 0; i < n; i++) {
        acc = (acc << 8) | p[i];
        bits += 8;
        while (bits >= 5) {
            *out++ = abc[(acc >> (bits - 5)) & 31];
            bits -= 5;
        }
    }
    if (bits > 0) *out++ = abc[(acc << (5 - bits)) & 31];
    *out = '\0';
}

/* base64url without padding (a malloc'd string; NULL when out of memory). */
static char *base64url(const unsigned char *p, size_t n)
{
    char *s = malloc(4 * ((n + 2) / 3) + 1);
    if (!s) return NULL;
    int len = EVP_EncodeBlock((unsigned char *)s, p, (int)n);
    while (len > 0 && s[len - 1] == '=') len--;
    s[len] = '\0';
    for (char *c = s; *c; c++) *c = *c == '+' ? '-' : *c == '/' ? '_' : *c;
    return s;
}

/* The text form of data (n bytes) behind the prefix bytes pre (npre of them), checksummed. */
static void encode_key(char *out, const unsigned char *pre, size_t npre, const unsigned char *data)
{
    unsigned char buf[2 + 32 + 2];
    memcpy(buf, pre, npre);
    memcpy(buf + npre, data, 32);
    uint16_t crc = crc16(buf, npre + 32);
    buf[npre + 32] = (unsigned char)(crc & 0xff);
    buf[npre + 33] = (unsigned char)(crc >> 8);
    base32(out, buf, npre + 34);
}

int natscreds_key_new(natscreds_key *k, char type)
{
    int prefix = prefix_of(type);
    if (prefix < 0 || RAND_bytes(k->raw, sizeof k->raw) != 1) return -1;
    EVP_PKEY *pk = EVP_PKEY_new_raw_private_key(EVP_PKEY_ED25519, NULL, k->raw, sizeof k->raw);
    unsigned char pub[32];
    size_t npub = sizeof pub;
    int ok = pk && EVP_PKEY_get_raw_public_key(pk, pub, &npub) == 1 && npub == sizeof pub;
    EVP_PKEY_free(pk);
    if (!ok) return -1;
    unsigned char p1 = (unsigned char)prefix;
    encode_key(k->pub, &p1, 1, pub);
    unsigned char p2[2] = { (unsigned char)(PREFIX_SEED | (prefix >> 5)), (unsigned char)((prefix & 31) << 3) };
    encode_key(k->seed, p2, 2, k->raw);
    return 0;
}

/* The ed25519 signature of msg by k, base64url (malloc'd; NULL on failure). */
static char *sign(const natscreds_key *k, const char *msg)
{
    EVP_PKEY *pk = EVP_PKEY_new_raw_private_key(EVP_PKEY_ED25519, NULL, k->raw, sizeof k->raw);
    EVP_MD_CTX *md = EVP_MD_CTX_new();
    unsigned char sig[64];
    size_t nsig = sizeof sig;
    int ok = pk && md && EVP_DigestSignInit(md, NULL, NULL, NULL, pk) == 1 &&
             EVP_DigestSign(md, sig, &nsig, (const unsigned char *)msg, strlen(msg)) == 1;
    EVP_MD_CTX_free(md);
    EVP_PKEY_free(pk);
    return ok ? base64url(sig, nsig) : NULL;
}

/* The claims JSON of subject signed by issuer, with jti ("": the text whose hash is the jti). */
static int claims(char *out, size_t cap, const char *jti, long iat, const natscreds_key *issuer,
                  const natscreds_key *subject, const char *name)
{
    static const char *const nats_of[] = {
        ['O'] = "{\"type\":\"operator\",\"version\":2}",
        ['A'] = "{\"limits\":{\"subs\":-1,\"data\":-1,\"payload\":-1,\"imports\":-1,\"exports\":-1,\"wildcards\":true,"
                "\"conn\":-1,\"leaf\":-1},\"default_permissions\":{\"pub\":{},\"sub\":{}},\"type\":\"account\",\"version\":2}",
        ['U'] = "{\"pub\":{},\"sub\":{},\"subs\":-1,\"data\":-1,\"payload\":-1,\"type\":\"user\",\"version\":2}",
    };
    return snprintf(out, cap, "{\"jti\":\"%s\",\"iat\":%ld,\"iss\":\"%s\",\"name\":\"%s\",\"sub\":\"%s\",\"nats\":%s}", jti,
                    iat, issuer->pub, name, subject->pub, nats_of[(unsigned char)subject->pub[0]]);
}

char *natscreds_jwt(const natscreds_key *issuer, const natscreds_key *subject, const char *name)
{
    char t = subject->pub[0];
    if (t != 'O' && t != 'A' && t != 'U') return NULL;
    long iat = (long)time(NULL);
    char body[1024], jti[64];
    /* jti: the SHA-512/256 of the claims without it, base32 (as the NATS JWT library does) */
    int n = claims(body, sizeof body, "", iat, issuer, subject, name);
    unsigned char h[32];
    unsigned int nh = sizeof h;
    if (n < 0 || (size_t)n >= sizeof body || EVP_Digest(body, (size_t)n, h, &nh, EVP_sha512_256(), NULL) != 1) return NULL;
    base32(jti, h, nh);
    n = claims(body, sizeof body, jti, iat, issuer, subject, name);
    if (n < 0 || (size_t)n >= sizeof body) return NULL;
    static const char header[] = "{\"typ\":\"JWT\",\"alg\":\"ed25519-nkey\"}";
    char *h64 = base64url((const unsigned char *)header, strlen(header)), *c64 = base64url((const unsigned char *)body, (size_t)n);
    char *jwt = NULL, *sig = NULL;
    if (h64 && c64) {
        size_t cap = strlen(h64) + strlen(c64) + 2 + 90;
        jwt = malloc(cap);
        if (jwt) {
            snprintf(jwt, cap, "%s.%s", h64, c64);
            sig = sign(issuer, jwt);
            if (sig) snprintf(jwt + strlen(jwt), cap - strlen(jwt), ".%s", sig);
        }
    }
    if (!sig) {
        free(jwt);
        jwt = NULL;
    }
    free(sig);
    free(h64);
    free(c64);
    return jwt;
}

/* Writes text to path with mode. 0 on success. */
static int write_text(const char *path, const char *text, mode_t mode)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, mode);
    if (fd < 0) return -1;
    size_t n = strlen(text);
    int rc = write(fd, text, n) == (ssize_t)n ? 0 : -1;
    return close(fd) == 0 ? rc : -1;
}

int natscreds_write(const char *path, const char *jwt, const char *seed)
{
    static const char fmt[] = "-----BEGIN NATS USER JWT-----\n%s\n------END NATS USER JWT------\n\n"
                              "************************* IMPORTANT *************************\n"
                              "NKEY Seed printed below can be used to sign and prove identity.\n"
                              "NKEYs are sensitive and should be treated as secrets.\n\n"
                              "-----BEGIN USER NKEY SEED-----\n%s\n------END USER NKEY SEED------\n\n"
                              "*************************************************************\n";
    size_t cap = sizeof fmt + strlen(jwt) + strlen(seed);
    char *text = malloc(cap);
    if (!text) return -1;
    snprintf(text, cap, fmt, jwt, seed);
    int rc = write_text(path, text, 0600);
    free(text);
    return rc;
}

int natscreds_setup(const char *dir, natscreds_key *account)
{
    natscreds_key op, acc, user;
    if (natscreds_key_new(&op, 'O') || natscreds_key_new(&acc, 'A') || natscreds_key_new(&user, 'U')) return -1;
    char *op_jwt = natscreds_jwt(&op, &op, "strandcast-op"), *acc_jwt = natscreds_jwt(&op, &acc, "strandcast"),
         *user_jwt = natscreds_jwt(&acc, &user, "strandcastd");
    char path[512], conf[4096];
    int rc = -1;
    if (op_jwt && acc_jwt && user_jwt) {
        snprintf(path, sizeof path, "%s/op.jwt", dir);
        int n = snprintf(conf, sizeof conf, "operator: \"%s\"\nresolver: MEMORY\nresolver_preload: {\n  %s: \"%s\"\n}\n", path,
                         acc.pub, acc_jwt);
        rc = n > 0 && (size_t)n < sizeof conf && write_text(path, op_jwt, 0644) == 0 ? 0 : -1;
        snprintf(path, sizeof path, "%s/server.conf", dir);
        if (rc == 0) rc = write_text(path, conf, 0644);
        snprintf(path, sizeof path, "%s/user.creds", dir);
        if (rc == 0) rc = natscreds_write(path, user_jwt, user.seed);
    }
    if (rc == 0 && account) *account = acc;
    free(op_jwt);
    free(acc_jwt);
    free(user_jwt);
    return rc;
}
