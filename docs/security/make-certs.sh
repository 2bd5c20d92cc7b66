#!/bin/sh
# Make a certificate authority, a server certificate for 127.0.0.1 / localhost, and one client
# certificate per name given (for mutual TLS: the name is the certificate's common name, the
# user of docs/security/server-mtls.json5). EC P-256 keys, valid DAYS days (default 365).
#
#   sh docs/security/make-certs.sh                       # docs/security/tls: the configs' paths
#   sh docs/security/make-certs.sh docs/security/tls alice bob   # with client certificates (mTLS)
#
# Keep ca.key offline: whoever has it can make certificates the server accepts.
set -eu
dir=${1:-docs/security/tls}  # the folder the shipped configs name, from the checkout's root
if [ $# -gt 0 ]; then shift; fi
days=${DAYS:-365}
mkdir -p "$dir"
cd "$dir"
umask 077
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days "$days" \
  -keyout ca.key -out ca.pem -subj "/CN=simx certificate authority" 2>/dev/null
cert() {  # cert NAME SUBJECT_ALT_NAMES
  openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes \
    -keyout "$1.key" -out "$1.csr" -subj "/CN=$1" 2>/dev/null
  printf 'basicConstraints=CA:FALSE\nkeyUsage=digitalSignature\nextendedKeyUsage=serverAuth,clientAuth\nsubjectAltName=%s\n' \
    "$2" > "$1.ext"
  openssl x509 -req -in "$1.csr" -CA ca.pem -CAkey ca.key -CAcreateserial -days "$days" \
    -extfile "$1.ext" -out "$1.pem" 2>/dev/null
  rm -f "$1.csr" "$1.ext"
}
cert server "DNS:localhost,IP:127.0.0.1"
for name in "$@"; do
  cert "$name" "DNS:$name"
done
chmod 644 ca.pem ./*.pem
echo "made in $dir: ca.pem ca.key server.pem server.key${*:+ and a .pem/.key for: $*}"
