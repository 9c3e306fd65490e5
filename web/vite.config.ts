import { defineConfig } from "vite";

// The bundle is static and self-contained (no CDN): the distlab server serves web/dist.
// `npm run dev` proxies the API and the WebSocket to a server on 127.0.0.1:8080.
export default defineConfig({
  base: "./",
  build: { outDir: "dist", emptyOutDir: true, sourcemap: true, chunkSizeWarningLimit: 1500 },
  server: {
    fs: { allow: [".."] }, // shaders/ lives beside web/
    proxy: {
      "/api": "http://127.0.0.1:8080",
      "/ws": { target: "ws://127.0.0.1:8080", ws: true },
    },
  },
});
