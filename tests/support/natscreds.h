/* Test support: NATS decentralized auth made here, as nsc makes it: NKeys (ed25519, OpenSSL),
 * operator -> account -> user JWTs, .creds files and nats-server's operator-mode configuration. */
#ifndef TESTS_NATSCREDS_H
#define TESTS_NATSCREDS_H

#include <stddef.h>

/* An NKey pair in NATS's text form: public key (56 characters, 'O', 'A' or 'U' first) and seed
 * (58 characters, "SO", "SA" or "SU" first). */
typedef struct natscreds_key {
    unsigned char raw[32]; /* the ed25519 private key */
    char pub[64];
    char seed[64];
} natscreds_key;

/* A fresh random key pair of type 'O' (operator), 'A' (account) or 'U' (user). 0 on success. */
int natscreds_key_new(natscreds_key *k, char type);

/* The JWT issuer signs for subject (malloc'd, the caller frees; NULL on failure): an operator's
 * (self-signed: issuer == subject), an account's (issuer its operator) or a user's (issuer its
 * account), by subject's type, named name, without limits or permissions. */
char *natscreds_jwt(const natscreds_key *issuer, const natscreds_key *subject, const char *name);

/* Writes a .creds file (mode 0600) holding jwt and seed in nsc's layout, the one libnats'
 * natsOptions_SetUserCredentialsFromFiles reads. 0 on success. */
int natscreds_write(const char *path, const char *jwt, const char *seed);

/* A whole set-up in the existing folder dir: an operator, an account and a user of it. Writes
 * dir/op.jwt, dir/server.conf (nats-server in operator mode trusting op.jwt, the account's JWT
 * preloaded in a memory resolver) and dir/user.creds; the account's key goes to *account when
 * not NULL (to sign other users with). 0 on success. */
int natscreds_setup(const char *dir, natscreds_key *account);

#endif
