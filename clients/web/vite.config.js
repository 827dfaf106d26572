import { defineConfig } from 'vite';

// Relative asset URLs, so that dist/ works at / and under a prefix such as /viewer/.
export default defineConfig({
  base: './',
  build: { outDir: 'dist', emptyOutDir: true, sourcemap: false, chunkSizeWarningLimit: 2000 },
});
